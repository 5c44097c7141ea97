"""A point of the search space as a run's inputs, in the case core's grammar of targets (case/targets.py: FMU
parameters, faults.N.*, initial.*, gust.*, waypoints.K.*), so that one evaluation runs exactly as a campaign case does.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..case import targets
from .spec import Dimension, SearchBase


def values_at(dimensions: list[Dimension], unit: np.ndarray) -> dict[str, float | int]:
    """The dimensions' values at a point of the unit cube."""
    return {d.name: d.value(float(u)) for d, u in zip(dimensions, unit)}


def case_parameters(base: SearchBase, values: dict[str, float | int]) -> dict[str, object]:
    """The run's parameters: base.parameters, then the point's (instance.name and faults.N.field keys)."""
    return targets.resolve([(d.target, values[d.name]) for d in base.dimensions], base.parameters,
                           base.trajectory.trajectory.start, base.faults, base.gust)


def case_faults(base: SearchBase, parameters: dict) -> list:
    """base.faults with the point's faults.N.field values (for a replay's fault file)."""
    return targets.with_fault_fields(base.faults, parameters)


def moved_waypoints(base: SearchBase, parameters: dict) -> list[dict] | None:
    """The mission's waypoints with the point's offsets (None: no waypoint moves)."""
    return targets.moved_waypoints(base.waypoints, parameters)


def case_flight(base: SearchBase, parameters: dict) -> tuple[SearchBase, dict]:
    """(base with the moved mission's flight, the parameters without the waypoint offsets); unchanged without any."""
    flight, rest = targets.moved_flight(base.trajectory, base.waypoints, parameters)
    return (base, parameters) if flight is base.trajectory else (dataclasses.replace(base, trajectory=flight), rest)


def mission_csv(rows: list[dict]) -> str:
    """Waypoints as a mission CSV (tiltload run --trajectory) whose numbers read back exactly (repr)."""
    from ....scenario_fmu.waypoints import FIELDS

    columns = [f for f in FIELDS if any(f in r for r in rows)]
    lines = [",".join(columns)]
    lines += [",".join(repr(float(r[c])) if c in r else "" for c in columns) for r in rows]
    return "\n".join(lines) + "\n"

"""A point of the search space as a run's inputs: the FMU parameters (instance.name) and fault fields a campaign case
sets (`faults.N.start|end|value`), so that one evaluation runs exactly as a campaign case does.

- `instance.name`: the parameter, e.g. plant.m_L, scenario.steady_wind_x, scenario.dryden (integer);
- `faults.N.start|end|value`: fault N's field; `faults.N.duration`: its end = its start + the duration;
- `initial.x|y|z`: the plant's initial load position offset from the trajectory's start (plant.x_0 ...); the
  controller's estimator keeps the start it is told (the offset is what it does not know);
- `gust.amplitude|direction|start|duration|rise`: a trapezoidal gust of horizontal wind velocity (m/s; direction in
  degrees from x), rising over `rise` s, written into the scenario FMU's wind profile (4 rows, held zero outside);
- `waypoints.K.t|x|y|z|psi`: an offset added to waypoint K of the mission (base.trajectory, a waypoint file); the
  worker makes the moved mission's minimum-jerk reference as `tiltload run --trajectory` does from a file
  (scenario_fmu/choice.py), so the plant starts at the moved first waypoint and the feasibility check judges it.
"""

from __future__ import annotations

import math

import numpy as np

from .spec import Dimension, SearchBase


def values_at(dimensions: list[Dimension], unit: np.ndarray) -> dict[str, float | int]:
    """The dimensions' values at a point of the unit cube."""
    return {d.name: d.value(float(u)) for d, u in zip(dimensions, unit)}


def gust_profile(gust: dict) -> dict[str, float | int]:
    """The scenario FMU's wind profile parameters of a trapezoidal gust."""
    a, heading = float(gust["amplitude"]), math.radians(float(gust["direction"]))
    start, duration = float(gust["start"]), float(gust["duration"])
    rise = min(float(gust["rise"]), duration / 3)
    rows = [(start, 0.0), (start + rise, a), (start + duration - rise, a), (start + duration, 0.0)]
    out: dict[str, float | int] = {"scenario.wind_profile_count": len(rows)}
    for i, (t, speed) in enumerate(rows):
        out[f"scenario.wind_profile_t_{i}"] = t
        out[f"scenario.wind_profile_x_{i}"] = speed * math.cos(heading)
        out[f"scenario.wind_profile_y_{i}"] = speed * math.sin(heading)
        out[f"scenario.wind_profile_z_{i}"] = 0.0
    return out


def case_parameters(base: SearchBase, values: dict[str, float | int]) -> dict[str, object]:
    """The run's parameters: base.parameters, then the point's (instance.name and faults.N.field keys)."""
    parameters: dict[str, object] = dict(base.parameters)
    gust = dict(base.gust) if base.gust is not None else None
    start = base.trajectory.trajectory.start
    durations = []
    for dim in base.dimensions:
        v, target = values[dim.name], dim.target
        kind, _, rest = target.partition(".")
        if kind == "gust":
            gust[rest] = v
        elif kind == "initial":
            parameters[f"plant.{rest}_0"] = float(start["xyz".index(rest)]) + v
        elif kind == "waypoints":
            parameters[target] = float(v)  # resolved into the flight by case_flight, in the worker
        elif kind == "faults" and target.endswith(".duration"):
            durations.append((int(rest.split(".")[0]), v))
        else:
            parameters[target] = v
    for n, duration in durations:  # after the starts: a duration counts from the fault's (searched) start
        begin = parameters.get(f"faults.{n}.start", base.faults[n].get("start", 0.0))
        parameters[f"faults.{n}.end"] = float(begin) + duration
    if gust is not None:
        parameters.update(gust_profile(gust))
    return parameters


def case_faults(base: SearchBase, parameters: dict) -> list:
    """base.faults with the point's faults.N.field values (for a replay's fault file)."""
    import copy

    faults = copy.deepcopy(base.faults)
    for key, value in parameters.items():
        if key.startswith("faults."):
            _, index, field = key.split(".")
            faults[int(index)][field] = value
    return faults


def moved_waypoints(base: SearchBase, parameters: dict) -> list[dict] | None:
    """The mission's waypoints with the point's offsets (None: no waypoint moves)."""
    offsets = {k: v for k, v in parameters.items() if k.startswith("waypoints.")}
    if not offsets:
        return None
    rows = [dict(r) for r in base.waypoints]
    for key, offset in offsets.items():
        _, k, field = key.split(".")
        rows[int(k)][field] = rows[int(k)].get(field, 0.0) + float(offset)
    return rows


def case_flight(base: SearchBase, parameters: dict) -> tuple[SearchBase, dict]:
    """(base with the moved mission's flight, the parameters without the waypoint offsets); unchanged without any.
    A moved mission that is no mission (waypoints out of time order) raises ScenarioFileError: the case's own."""
    rows = moved_waypoints(base, parameters)
    if rows is None:
        return base, parameters
    import dataclasses
    from pathlib import Path

    from ....scenario_fmu import twin, waypoints
    from ....scenario_fmu.choice import Trajectory

    flight = base.trajectory
    source = Path(flight.trajectory.source)
    waypoints.check(rows, [f"waypoint {i}" for i in range(len(rows))], f"{source.name} (moved)")
    ref = waypoints.minimum_jerk(rows)  # as choice.read_file makes a mission file's reference
    trajectory = Trajectory(source.stem, twin.WAYPOINTS, (), ref.start, ref.duration, str(source),
                            tuple(map(tuple, ref.knots().tolist())))
    moved = dataclasses.replace(flight, trajectory=trajectory)
    return dataclasses.replace(base, trajectory=moved), {k: v for k, v in parameters.items() if not k.startswith("waypoints.")}


def mission_csv(rows: list[dict]) -> str:
    """Waypoints as a mission CSV (tiltload run --trajectory) whose numbers read back exactly (repr)."""
    from ....scenario_fmu.waypoints import FIELDS

    columns = [f for f in FIELDS if any(f in r for r in rows)]
    lines = [",".join(columns)]
    lines += [",".join(repr(float(r[c])) if c in r else "" for c in columns) for r in rows]
    return "\n".join(lines) + "\n"

"""A campaign case's system: the tiltload loop the spec's base describes, with the case's controller, seed, parameters
and faults; and, for a campaign from a snapshot, the system the snapshot was taken of."""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Protocol

from ..loop import default_stop, default_system
from .spec import Flight


class LoopBase(Protocol):
    """What a case's loop is built from: a campaign's base (spec.CampaignBase) or a falsification's (SearchBase)."""

    scenario: str
    trajectory: Flight
    stop_time: float | None
    gusts: bool
    faults: list | None


def flight_of(base: LoopBase) -> Flight:
    """base.trajectory: the spec's Flight, or a thesis trajectory's number."""
    flight = base.trajectory
    if isinstance(flight, Flight):
        return flight
    from ..inputs import trajectory as as_trajectory

    return Flight(as_trajectory(flight))


def stop_of(base: LoopBase) -> float:
    """The run's stop time: the spec's, else the trajectory's own."""
    return base.stop_time or default_stop(flight_of(base).trajectory)


def case_system(fmu_dir: Path, base: LoopBase, controller: str, seed: int, parameters: dict):
    """The loop of the base (scenario, trajectory, gusts, faults) with a case's controller, seed and parameters (an
    instance.name or a faults.N.field each)."""
    from ...engine.faults.parse import parse

    is_fmu = controller not in ("dlqr", "mixed")
    flight = flight_of(base)
    system = default_system(fmu_dir, base.scenario, flight.trajectory, "mixed" if is_fmu else controller, seed,
                            Path(controller) if is_fmu else None, gusts=base.gusts, wind=dict(flight.wind))
    faults = copy.deepcopy(base.faults or [])
    for key, value in parameters.items():
        if key.startswith("faults."):
            _, index, field = key.split(".")
            faults[int(index)][field] = value
            continue
        instance, _, name = key.partition(".")
        system.instance(instance).parameters[name] = value
    system.faults = parse(faults) if faults else []
    return system


def branch_system(fmu_dir: Path, snap, faults, parameters: dict, controller: str):
    """The system a snapshot was taken of (its loop options, the FMUs of fmu_dir, the controller the spec names: a
    snapshot never says where a file is), with a case's faults (None: the run's own) and the snapshot's settings for
    its tunable parameters."""
    import dataclasses

    from ...engine.faults.parse import parse
    from ..loop_system import loop_system
    from ..options import snapshot_options

    opts = dataclasses.replace(snapshot_options(snap.application, "base.snapshot"), fmus=fmu_dir)
    if opts.controller_fmu is not None:
        opts = dataclasses.replace(opts, controller=controller, controller_fmu=Path(controller))
    if faults is not None:
        opts = dataclasses.replace(opts, faults=None)
    system = loop_system(opts, fmu_dir, prepared=True).system
    settings: dict[str, dict] = {}
    if faults is not None:
        faults = copy.deepcopy(faults)
    for key, value in parameters.items():
        if key.startswith("faults."):
            _, index, field = key.split(".")
            faults[int(index)][field] = value
        else:
            instance, _, name = key.partition(".")
            settings.setdefault(instance, {})[name] = value
    if faults is not None:
        system.faults = parse(faults) if faults else []
    return system, dataclasses.replace(snap, settings=settings)

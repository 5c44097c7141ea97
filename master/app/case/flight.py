"""What the scenario FMU flies in every run of a case set, and how its feasibility is checked: a spec's
base.trajectory, base.wind, base.allow_infeasible and base.max_tilt, resolved (files read) once."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

from ....scenario_fmu.choice import Trajectory
from ..loop.defaults import MAX_TILT
from .spec_file import SpecError


@dataclass(frozen=True)
class Flight:
    trajectory: Trajectory
    wind: tuple[tuple[str, object], ...] = ()  # the scenario FMU's wind parameters
    allow_infeasible: bool = False
    max_tilt: float = MAX_TILT

    def __str__(self) -> str:
        return self.trajectory.label


class LoopBase(Protocol):
    """What every run of a case set shares: a campaign's base (campaign.spec.CampaignBase) or a search's
    (falsify.spec.SearchBase)."""

    scenario: str
    trajectory: Flight
    stop_time: float | None
    gusts: bool
    faults: list | None


def read_flight(base: dict, path: Path) -> Flight:
    """base.trajectory and base.wind read (relative to the spec), with the feasibility policy."""
    from ....scenario_fmu.files import ScenarioFileError
    from ...engine.user_files import UserFileError
    from ..loop.inputs import read_wind
    from ..loop.inputs import trajectory as as_trajectory

    try:
        trajectory = as_trajectory(base.get("trajectory", 1), path.parent)
        wind = tuple(read_wind(path.parent / base["wind"]).items()) if "wind" in base else ()
    except (ScenarioFileError, UserFileError) as err:
        raise SpecError(f"{path}: base: {err}") from None
    return Flight(trajectory, wind, base.get("allow_infeasible", False), base.get("max_tilt", MAX_TILT))


def flight_of(base: LoopBase) -> Flight:
    """base.trajectory: the spec's Flight, or a thesis trajectory's number."""
    flight = base.trajectory
    if isinstance(flight, Flight):
        return flight
    from ..loop.inputs import trajectory as as_trajectory

    return Flight(as_trajectory(flight))


def stop_of(base: LoopBase) -> float:
    """The run's stop time: the spec's, else the trajectory's own."""
    from ..loop.thesis import default_stop

    return base.stop_time or default_stop(flight_of(base).trajectory)

"""The one grammar of what varies between the runs of a case set (campaigns and searches alike): a target name and a
value. docs/campaigns.md and docs/falsification.md list the same targets:

- `instance.name`: an FMU parameter, e.g. plant.m_L, scenario.steady_wind_x, scenario.dryden (integer);
- `faults.N.start|end|value`: fault N's field; `faults.N.duration`: its end = its start + the duration;
- `initial.x|y|z`: the plant's initial load position offset from the trajectory's start (plant.x_0 ...); the
  controller's estimator keeps the start it is told (the offset is what it does not know);
- `gust.amplitude|direction|start|duration|rise`: a trapezoidal gust of horizontal wind velocity (m/s; direction in
  degrees from x), rising over `rise` s, written into the scenario FMU's wind profile (4 rows, held zero outside);
- `waypoints.K.t|x|y|z|psi`: an offset added to waypoint K of the mission (base.trajectory, a waypoint file); the
  worker makes the moved mission's minimum-jerk reference as `tiltload run --trajectory` does from a file
  (scenario_fmu/choice.py), so the plant starts at the moved first waypoint and the feasibility check judges it.

`resolve` turns a point's target values into a run's parameters (instance.name and faults.N.field keys, and the
waypoint offsets that `moved_flight` turns into the flight); the case's system builder (system.py) applies them.
"""

from __future__ import annotations

import copy
import math
import re

from ..loop.thesis import CONTROLLER, PLANT, SCENARIO, SENSORS

LOOP_INSTANCES = (PLANT, SCENARIO, CONTROLLER, SENSORS)
FAULT_FIELDS = ("start", "end", "value", "duration")
GUST_FIELDS = ("amplitude", "direction", "start", "duration", "rise")
GUST_DEFAULTS = {"amplitude": 0.0, "direction": 0.0, "start": 0.0, "duration": 1.0, "rise": 0.2}
WAYPOINT_FIELDS = ("t", "x", "y", "z", "psi")
TARGET_PATTERN = (rf"^([A-Za-z_]\w*\.[A-Za-z_]\w*|faults\.\d+\.({'|'.join(FAULT_FIELDS)})|gust\.({'|'.join(GUST_FIELDS)})|"
                  rf"initial\.[xyz]|waypoints\.\d+\.({'|'.join(WAYPOINT_FIELDS)}))$")
_FAULT = re.compile(r"^faults\.(\d+)\.(\w+)$")


def fault_field(target: str) -> tuple[int, str] | None:
    """(N, field) of a faults.N.field target; None for any other."""
    m = _FAULT.match(target)
    return (int(m.group(1)), m.group(2)) if m else None


def kind_problem(target: str) -> str | None:
    """Why a target (already of TARGET_PATTERN's form) names nothing of the loop, or None."""
    kind, _, rest = target.partition(".")
    if kind == "gust" and rest not in GUST_FIELDS:
        return f"a gust has {', '.join(GUST_FIELDS)}, not {rest}"
    if kind not in ("gust", "initial", "faults", "waypoints") and kind not in LOOP_INSTANCES:
        return (f"{target} is neither gust.*, initial.*, faults.N.*, waypoints.K.* nor a parameter of the loop's instances "
                f"({', '.join(LOOP_INSTANCES)})")
    return None


def with_fault_fields(faults: list, parameters: dict) -> list:
    """A copy of faults (their JSON form) with the parameters' faults.N.field values."""
    faults = copy.deepcopy(faults)
    for key, value in parameters.items():
        named = fault_field(key)
        if named is not None:
            faults[named[0]][named[1]] = value
    return faults


def instance_settings(parameters: dict) -> dict:
    """The parameters' instance.name entries (FMU parameters), in order."""
    return {k: v for k, v in parameters.items() if not k.startswith(("faults.", "waypoints."))}


def gust_profile(gust: dict) -> dict[str, float | int]:
    """The scenario FMU's wind profile parameters of a trapezoidal gust."""
    a, heading = float(gust["amplitude"]), math.radians(float(gust["direction"]))
    start, duration = float(gust["start"]), float(gust["duration"])
    rise = min(float(gust["rise"]), duration / 3)
    rows = [(start, 0.0), (start + rise, a), (start + duration - rise, a), (start + duration, 0.0)]
    out: dict[str, float | int] = {f"{SCENARIO}.wind_profile_count": len(rows)}
    for i, (t, speed) in enumerate(rows):
        out[f"{SCENARIO}.wind_profile_t_{i}"] = t
        out[f"{SCENARIO}.wind_profile_x_{i}"] = speed * math.cos(heading)
        out[f"{SCENARIO}.wind_profile_y_{i}"] = speed * math.sin(heading)
        out[f"{SCENARIO}.wind_profile_z_{i}"] = 0.0
    return out


def resolve(values: list[tuple[str, object]], base_parameters: dict, start, faults: list, gust: dict | None) -> dict:
    """A run's parameters: base_parameters, then each (target, value) of the point (instance.name and faults.N.field
    keys; waypoint offsets kept for moved_flight). start: the trajectory's start (initial.* offsets it); gust: the
    gust's fixed fields (None: no gust is varied)."""
    parameters: dict[str, object] = dict(base_parameters)
    gust = dict(gust) if gust is not None else None
    durations = []
    for target, v in values:
        kind, _, rest = target.partition(".")
        if kind == "gust":
            gust[rest] = v
        elif kind == "initial":
            parameters[f"{PLANT}.{rest}_0"] = float(start["xyz".index(rest)]) + v
        elif kind == "waypoints":
            parameters[target] = float(v)  # resolved into the flight by moved_flight, in the worker
        elif kind == "faults" and target.endswith(".duration"):
            durations.append((int(rest.split(".")[0]), v))
        else:
            parameters[target] = v
    for n, duration in durations:  # after the starts: a duration counts from the fault's (varied) start
        begin = parameters.get(f"faults.{n}.start", faults[n].get("start", 0.0))
        parameters[f"faults.{n}.end"] = float(begin) + duration
    if gust is not None:
        parameters.update(gust_profile(gust))
    return parameters


def moved_waypoints(waypoints: list[dict] | None, parameters: dict) -> list[dict] | None:
    """The mission's waypoints with the point's offsets (None: no waypoint moves)."""
    offsets = {k: v for k, v in parameters.items() if k.startswith("waypoints.")}
    if not offsets:
        return None
    rows = [dict(r) for r in waypoints]
    for key, offset in offsets.items():
        _, k, field = key.split(".")
        rows[int(k)][field] = rows[int(k)].get(field, 0.0) + float(offset)
    return rows


def moved_flight(flight, waypoints: list[dict] | None, parameters: dict):
    """(the flight with the moved mission, the parameters without the waypoint offsets); unchanged without any.
    A moved mission that is no mission (waypoints out of time order) raises ScenarioFileError: the case's own."""
    rows = moved_waypoints(waypoints, parameters)
    if rows is None:
        return flight, parameters
    import dataclasses
    from pathlib import Path

    from ....scenario_fmu import twin
    from ....scenario_fmu import waypoints as mission
    from ....scenario_fmu.choice import Trajectory

    source = Path(flight.trajectory.source)
    mission.check(rows, [f"waypoint {i}" for i in range(len(rows))], f"{source.name} (moved)")
    ref = mission.minimum_jerk(rows)  # as choice.read_file makes a mission file's reference
    trajectory = Trajectory(source.stem, twin.WAYPOINTS, (), ref.start, ref.duration, str(source),
                            tuple(map(tuple, ref.knots().tolist())))
    return dataclasses.replace(flight, trajectory=trajectory), {k: v for k, v in parameters.items()
                                                                if not k.startswith("waypoints.")}

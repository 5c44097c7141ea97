"""Falsification specifications (TOML or YAML): the campaign spec's base case, the requirements, the search space, the
budget and the optimizer; validated like a campaign spec (its reader, its base schema, its checks of faults and files).
The format, annotated: docs/falsification.md ("The spec").
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field
from pathlib import Path

from ..case.flight import Flight, read_flight
from ..case.spec_file import BASE_PROPERTIES, NAME, TARGET, SpecError, checked_faults, read_spec_file
from ..case.spec_file import SEED as SEED_SCHEMA
from ..case.targets import GUST_DEFAULTS, GUST_FIELDS, LOOP_INSTANCES, kind_problem
from ..loop.defaults import CONTROLLER, GUSTS, OUR_CONTROLLERS, SCENARIO, SEED
from .options import OPTIMIZERS


def _base_schema() -> dict:
    # one controller and a seed; a search branches from snapshots of its own (branching.py)
    props = {**copy.deepcopy(BASE_PROPERTIES), "controller": {"type": "string", "minLength": 1}, "seed": SEED_SCHEMA}
    return {"type": "object", "additionalProperties": False, "properties": props}


SCHEMA = {
    "type": "object", "additionalProperties": False, "required": ["name", "base", "requirements", "search", "budget"],
    "properties": {
        "name": NAME,
        "optimizer": {"enum": list(OPTIMIZERS)},
        "seed": {"type": "integer", "minimum": 0, "maximum": 2**32 - 1},
        "batch": {"type": "integer", "minimum": 1, "maximum": 1024},
        "base": _base_schema(),
        "requirements": {"type": "array", "minItems": 1, "items": {"oneOf": [
            {"type": "object", "additionalProperties": False, "required": ["name", "formula"], "properties": {
                "name": {"type": "string", "pattern": r"^[A-Za-z_]\w*$"},
                "formula": {"type": "string", "minLength": 1},
                "description": {"type": "string"}}},
            {"type": "object", "additionalProperties": False, "required": ["file"], "properties": {
                "file": {"type": "string", "minLength": 1},
                "name": {"type": "string", "minLength": 1}}}]}},
        "search": {"type": "array", "minItems": 1, "items": {
            "type": "object", "additionalProperties": False, "required": ["name", "target", "range"], "properties": {
                "name": {"type": "string", "pattern": r"^[A-Za-z_]\w*$"},
                "target": TARGET,
                "range": {"type": "array", "minItems": 2, "maxItems": 2, "items": {"type": "number"}},
                "integer": {"type": "boolean"}}}},
        "gust": {"type": "object", "additionalProperties": False,
                 "properties": {f: {"type": "number"} for f in GUST_FIELDS}},
        "budget": {"type": "object", "additionalProperties": False, "minProperties": 1, "properties": {
            "simulations": {"type": "integer", "minimum": 1, "maximum": 1000000},
            "seconds": {"type": "number", "exclusiveMinimum": 0}}},
    },
}


@dataclass(frozen=True)
class Dimension:
    """One axis of the search: a bounded range over a target (module docstring), rounded when integer."""

    name: str
    target: str
    low: float
    high: float
    integer: bool = False

    def value(self, unit: float) -> float | int:
        """The target's value at a point of [0, 1] along this axis."""
        v = self.low + min(max(unit, 0.0), 1.0) * (self.high - self.low)
        return int(round(v)) if self.integer else float(v)


@dataclass(frozen=True)
class Requirement:
    name: str
    formula: str  # rtamt's grammar (master/engine/requirement/stl)
    description: str = ""


@dataclass(frozen=True)
class BranchPoint:
    """Where every evaluation branches from (branching.py): the tick of the base case's snapshot, and a key that tells
    the snapshots of different bases apart."""

    ticks: int
    key: str


@dataclass(frozen=True)
class SearchBase:
    """What every evaluation of a falsification shares, as the workers get it (Falsification.base())."""

    scenario: str
    trajectory: Flight
    stop_time: float
    gusts: bool
    faults: list  # base.faults, their JSON form
    parameters: dict  # base.parameters (instance.name -> value)
    requirements: tuple[str, ...]  # the formulas
    requirement_names: tuple[str, ...]
    signals: tuple[str, ...]
    dimensions: tuple[Dimension, ...]
    gust: dict | None  # the gust's fixed fields, when a dimension targets gust.*
    controller: str
    seed: int
    waypoints: list | None  # the mission's waypoints, when a dimension moves one
    early_stop: bool = False  # an evaluation stops at its first decided violation (evaluate.py)
    branch: BranchPoint | None = None  # every evaluation goes on from the base case's snapshot (branching.py)


@dataclass
class Falsification:
    name: str
    scenario: str
    flight: Flight
    controller: str  # dlqr | mixed | an absolute FMU path
    loop_seed: int
    stop_time: float
    gusts: bool
    parameters: dict  # base.parameters (instance.name -> value)
    faults: list  # base.faults, their JSON form
    requirements: list[Requirement]
    dimensions: list[Dimension]
    gust: dict  # the gust's fixed fields (only used when a dimension targets gust.*)
    optimizer: str
    seed: int
    batch: int | None
    simulations: int | None
    seconds: float | None
    source: Path
    wind_file: Path | None = None
    trajectory_arg: str = "1"  # base.trajectory as tiltload run's --trajectory takes it (a file: its absolute path)
    signals: tuple[str, ...] = field(default=())  # every signal the requirements name
    waypoints: list = field(default_factory=list)  # a mission's waypoints ({t, x, y, z, ...}) when a dimension moves one
    wrapped: str | None = None  # base.controller as the spec names it, when it is a class's .py file wrapped on the fly

    @property
    def has_gust(self) -> bool:
        return any(d.target.startswith("gust.") for d in self.dimensions)

    def base(self) -> SearchBase:
        """What every evaluation shares, as the workers get it."""
        return SearchBase(self.scenario, self.flight, self.stop_time, self.gusts, self.faults, self.parameters,
                          tuple(r.formula for r in self.requirements), tuple(r.name for r in self.requirements),
                          tuple(self.signals), tuple(self.dimensions), self.gust if self.has_gust else None, self.controller,
                          self.loop_seed, self.waypoints or None)


def _validate(data: dict, path: Path) -> None:
    from ...engine.user_files import schema_problem

    problem = schema_problem(data, SCHEMA)  # the one validator of the user's files
    if problem is not None:
        raise SpecError(f"{path}: {problem}")


def _from_file(item: dict, i: int, path: Path) -> list[dict]:
    """The entries a {file, name} item names, as {name, formula, description} (the file read through user_files: its
    size, depth and numbers bounded; its entries checked by the requirements' own loader, master/engine/requirement/files.py)."""
    from ...engine.requirement.files import RequirementError, parse_entries
    from ...engine.user_files import UserFileError, read_yaml

    file = (path.parent / item["file"]).resolve()
    where = f"{path}: requirements.{i}.file: "
    if not file.is_file():
        raise SpecError(f"{where}no requirement file {file}")
    try:
        entries = parse_entries(read_yaml(file), f"{file}: ")
    except (UserFileError, RequirementError) as err:
        raise SpecError(f"{where}{err}") from None
    if "name" in item:
        entries = [e for e in entries if e.name == item["name"]]
        if not entries:
            import difflib

            names = [e.name for e in parse_entries(read_yaml(file), "")]
            close = difflib.get_close_matches(item["name"], names, n=3)
            hint = f" (did you mean {', '.join(close)}?)" if close else f" (it has {', '.join(names)})"
            raise SpecError(f"{path}: requirements.{i}.name: {file} has no requirement {item['name']}{hint}")
    return [{"name": e.name, "formula": e.text, "description": e.description} for e in entries]


def _requirements(items: list, path: Path) -> tuple[list[Requirement], tuple[str, ...]]:
    from ...engine.requirement import stl

    names, found, out = set(), [], []
    expanded = []
    for i, item in enumerate(items):
        expanded.extend((i, e) for e in (_from_file(item, i, path) if "file" in item else [item]))
    for i, item in expanded:
        if item["name"] in names:
            raise SpecError(f"{path}: requirements.{i}.name: {item['name']} is named twice")
        names.add(item["name"])
        try:
            node = stl.parse(item["formula"])
            stl.horizon(node)
        except stl.StlError as err:
            raise SpecError(f"{path}: requirements.{i}.formula: {err}") from None
        for s in stl.signals(node):
            if s not in found:
                found.append(s)
        out.append(Requirement(item["name"], item["formula"], item.get("description", "")))
    return out, tuple(found)


def _check_horizons(requirements: list[Requirement], stop: float, path: Path) -> None:
    """A requirement must be decidable by the run: its horizon within the stop time (a run reaches it: engine/edges.py,
    a window ending at the stop time is decided)."""
    from ...engine.requirement import stl

    for i, r in enumerate(requirements):
        h = stl.bounded_horizon(stl.parse(r.formula))
        if h > stop + 1e-9:
            raise SpecError(f"{path}: requirements.{i}.formula: its horizon ({h:g} s) is longer than the run (base.stop_time "
                            f"{stop:g} s): raise stop_time or shorten the windows")


def _check_signals(signals: tuple[str, ...], path: Path) -> None:
    """Each signal must be instance.variable of the loop (the instance names; the variable is checked against the
    built FMU's outputs before the search: runner.check_names)."""
    for s in signals:
        instance, _, variable = s.partition(".")
        if instance not in LOOP_INSTANCES or not variable or "." in variable:
            raise SpecError(f"{path}: requirements: signal {s} is not instance.variable of the loop "
                            f"({', '.join(LOOP_INSTANCES)})")


def _mission_rows(flight: Flight, path: Path) -> list[dict]:
    """The waypoints of base.trajectory's mission file (read through the master's input layer), for waypoints.K.*."""
    from ....scenario_fmu import waypoints
    from ....scenario_fmu.files import ScenarioFileError, read_rows, read_structured
    from ...engine.user_files import UserFileError
    from ..loop.inputs import READER

    source = Path(flight.trajectory.source) if flight.trajectory.source else None
    if source is None or not flight.trajectory.knots:
        raise SpecError(f"{path}: search: waypoints.K.* moves a mission's waypoint: base.trajectory must be a waypoint file")
    try:
        if source.suffix.lower() == ".csv":
            rows, _ = read_rows(source, waypoints.FIELDS, waypoints.REQUIRED, READER)
        else:
            rows = read_structured(source, READER)["waypoints"]
    except (ScenarioFileError, UserFileError) as err:
        raise SpecError(f"{path}: base.trajectory: {err}") from None
    return [{k: float(v) for k, v in row.items()} for row in rows]


def _dimensions(items: list, faults: list, flight: Flight, path: Path) -> list[Dimension]:
    out, names, targets = [], set(), set()
    for i, item in enumerate(items):
        where = f"{path}: search.{i}"
        low, high = item["range"]
        if not (math.isfinite(low) and math.isfinite(high)) or not low < high:
            raise SpecError(f"{where}.range: low must be below high (finite numbers), got [{low}, {high}]")
        if item["name"] in names:
            raise SpecError(f"{where}.name: {item['name']} is named twice")
        if item["target"] in targets:
            raise SpecError(f"{where}.target: {item['target']} is searched twice")
        names.add(item["name"])
        targets.add(item["target"])
        target = item["target"]
        problem = kind_problem(target)
        if problem:
            raise SpecError(f"{where}.target: {problem}")
        if target.startswith("gust.") and any(k.startswith("wind_profile") for k, _ in flight.wind):
            raise SpecError(f"{where}.target: a searched gust is written into the wind profile, and base.wind has one")
        if target in ("gust.duration", "gust.rise") and low <= 0:
            raise SpecError(f"{where}.range: a gust's {target[5:]} must be above 0 s")
        out.append(Dimension(item["name"], target, float(low), float(high), item.get("integer", False)))
    return out


def load(path: Path) -> Falsification:
    """Read and validate a falsification spec."""
    path = Path(path)
    data = read_spec_file(path)
    _validate(data, path)
    base = data["base"]
    controller = base.get("controller", CONTROLLER)
    wrapped = controller if controller.endswith(".py") else None
    if controller not in OUR_CONTROLLERS:
        if not (path.parent / controller).is_file():
            raise SpecError(f"{path}: base.controller: {controller} is neither dlqr, mixed, an existing controller FMU "
                            "nor a class's .py file")
        controller = str((path.parent / controller).resolve())
        if controller.endswith(".py"):  # wrapped as `run --controller my_controller.py` wraps it: the search runs its FMU
            from ..wrap.class_fmu import controller_fmu_of_file
            from ..wrap.wrap import WrapError

            try:
                controller = str(controller_fmu_of_file(Path(controller), field=f"{path}: base.controller"))
            except WrapError as err:
                raise SpecError(f"{path}: base.controller: {err}") from None
    faults = checked_faults(base, [(f"search.{i}.target", s["target"]) for i, s in enumerate(data["search"])], path)
    flight = read_flight(base, path)
    requirements, signals = _requirements(data["requirements"], path)
    _check_signals(signals, path)
    dimensions = _dimensions(data["search"], faults, flight, path)
    mission = _mission_rows(flight, path) if any(d.target.startswith("waypoints.") for d in dimensions) else []
    for i, d in enumerate(dimensions):
        if d.target.startswith("waypoints.") and int(d.target.split(".")[1]) >= len(mission):
            raise SpecError(f"{path}: search.{i}.target: {d.target} names a waypoint the mission does not have "
                            f"(it has {len(mission)}: 0 to {len(mission) - 1})")
    from ..loop.thesis import default_stop

    stop = base.get("stop_time") or default_stop(flight.trajectory)
    _check_horizons(requirements, float(stop), path)
    gust = {**GUST_DEFAULTS, **data.get("gust", {})}
    if gust["duration"] <= 0 or gust["rise"] <= 0:
        raise SpecError(f"{path}: gust: duration and rise must be above 0 s")
    budget = data["budget"]
    wind = (path.parent / base["wind"]).resolve() if "wind" in base else None
    raw = base.get("trajectory", 1)
    trajectory_arg = str((path.parent / raw).resolve()) if isinstance(raw, str) and (path.parent / raw).is_file() else str(raw)
    return Falsification(data["name"], base.get("scenario", SCENARIO), flight, controller, base.get("seed", SEED), float(stop),
                         base.get("gusts", GUSTS), dict(base.get("parameters", {})), faults, requirements, dimensions, gust,
                         data.get("optimizer", "cmaes"), data.get("seed", 0), data.get("batch"), budget.get("simulations"),
                         budget.get("seconds"), path, wind, trajectory_arg, signals, mission, wrapped)

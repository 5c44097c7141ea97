"""Campaign specifications (TOML or YAML): what is run, what varies, what is kept; validated against a JSON Schema,
then expanded into runs. The format, annotated: docs/campaigns.md ("The spec").
"""

from __future__ import annotations

import dataclasses
import hashlib
import itertools
import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

from ..case.case_set import Case
from ..case.flight import Flight, read_flight
from ..case.spec_file import BASE_PROPERTIES, NAME, SEED, TARGET, SpecError, checked_faults, read_spec_file
from ..case.targets import GUST_DEFAULTS, kind_problem, resolve
from ..loop.defaults import CONTROLLER as DEFAULT_CONTROLLER
from ..loop.defaults import GUSTS, OUR_CONTROLLERS
from ..loop.defaults import SCENARIO as DEFAULT_SCENARIO
from ..loop.defaults import SEED as DEFAULT_SEED

METRICS = ("ISE", "IADU", "max_tracking_error", "time_saturated", "zse_containment")
MAX_RUNS = 100_000  # runs in one campaign: as many as vary.samples may ask for; each run is a row, and the grid is counted first

SCHEMA = {
    "type": "object", "additionalProperties": False, "required": ["name", "base", "vary"],
    "properties": {
        "name": NAME,
        "base": {"type": "object", "additionalProperties": False, "properties": {
            **BASE_PROPERTIES,
            "controllers": {"type": "array", "minItems": 1, "uniqueItems": True, "items": {"type": "string", "minLength": 1}},
            "snapshot": {"type": "string", "minLength": 1}}},
        "vary": {"type": "object", "additionalProperties": False, "properties": {
            "seeds": {"type": "array", "minItems": 1, "uniqueItems": True,
                      "items": SEED},
            "method": {"enum": ["grid", "random", "lhs"]},
            "samples": {"type": "integer", "minimum": 1, "maximum": 100000},
            "sample_seed": {"type": "integer", "minimum": 0},
            "parameters": {"type": "array", "items": {
                "type": "object", "additionalProperties": False, "required": ["name", "targets"],
                "properties": {
                    "name": {"type": "string", "pattern": r"^[A-Za-z_]\w*$"},
                    "targets": {"type": "array", "minItems": 1, "items": TARGET},
                    "values": {"type": "array", "minItems": 1, "items": {"type": "number"}},
                    "range": {"type": "array", "minItems": 2, "maxItems": 2, "items": {"type": "number"}}}}}}},
        "keep": {"type": "object", "additionalProperties": False, "properties": {
            "metrics": {"type": "array", "items": {"enum": list(METRICS)}},
            "logs": {"type": "boolean"},
            "requirements": {"type": "string"}}},
    },
}


@dataclass(frozen=True)
class CampaignBase:
    """What every run of a campaign shares, as the workers get it (Campaign.base())."""

    scenario: str
    trajectory: Flight
    stop_time: float | None  # None: the trajectory's own
    gusts: bool
    faults: list | None = None  # their JSON form; None: a branch keeps its run's own
    keep_metrics: tuple[str, ...] = METRICS
    branch: bool = False  # the cases branch from a snapshot (base.snapshot)
    requirements: tuple[tuple[str, str], ...] = ()  # keep.requirements: (name, STL) of each
    feasibility: dict = field(default_factory=dict)  # the client's verdicts (worker.feasibility_verdicts), by their key


@dataclass
class Campaign:
    name: str
    scenario: str
    trajectory: Flight
    stop_time: float | None
    gusts: bool
    keep_metrics: tuple[str, ...]
    keep_logs: bool
    faults: list | None  # their JSON form; "faults.N.field" targets vary them; None: a branch keeps its run's own
    varied: list[str]
    cases: list[Case]
    source: Path
    snapshot: Path | None = None  # the cases branch from this snapshot (base.snapshot)
    branch_start: float = 0.0  # the snapshot's time (s)
    requirements: tuple = ()  # keep.requirements: (name, STL) of each, judged on every run (columns NAME_verdict, NAME_robustness)
    wrapped: tuple = ()  # (as base.controllers names it, its FMU) of each class's .py file wrapped on the fly

    def base(self) -> CampaignBase:
        """What every run shares, as the workers get it (run_case's `base`)."""
        return CampaignBase(self.scenario, self.trajectory, self.stop_time, self.gusts, self.faults, tuple(self.keep_metrics),
                            self.snapshot is not None, tuple(tuple(r) for r in self.requirements))


def validate(data: dict, path: Path) -> None:
    from ...engine.user_files import schema_problem

    problem = schema_problem(data, SCHEMA)
    if problem:
        raise SpecError(f"{path}: {problem}")


def _points(vary: dict, path: Path, per_point: int = 1) -> list[dict[str, float]]:
    """The varied parameters' points; refused before any is built when, with per_point runs each (controllers times
    seeds), they would be more than MAX_RUNS."""
    params = vary.get("parameters", [])
    method = vary.get("method", "grid")
    names = [p["name"] for p in params]
    if len(set(names)) != len(names):
        raise SpecError(f"{path}: vary.parameters: two parameters are named alike")
    if not params:
        return [{}]
    if method == "grid":
        for p in params:
            if "values" not in p or "range" in p:
                raise SpecError(f"{path}: vary.parameters.{p['name']}: a grid takes values = [...]")
        runs = math.prod(len(p["values"]) for p in params) * per_point
        if runs > MAX_RUNS:
            raise SpecError(f"{path}: vary: the grid makes {runs} runs "
                            f"({' x '.join(str(len(p['values'])) for p in params)} points, {per_point} runs each: controllers x seeds); "
                            f"a campaign has at most {MAX_RUNS}")
        return [dict(zip(names, combo)) for combo in itertools.product(*(p["values"] for p in params))]
    for p in params:
        if "range" not in p or "values" in p:
            raise SpecError(f"{path}: vary.parameters.{p['name']}: {method} sampling takes range = [low, high]")
        if not p["range"][0] < p["range"][1]:
            raise SpecError(f"{path}: vary.parameters.{p['name']}.range: low must be below high")
    from scipy.stats import qmc

    n = vary.get("samples")
    if n is None:
        raise SpecError(f"{path}: vary.samples: {method} sampling needs the number of samples")
    if n * per_point > MAX_RUNS:
        raise SpecError(f"{path}: vary: {n} samples, {per_point} runs each (controllers x seeds), make {n * per_point} runs; "
                        f"a campaign has at most {MAX_RUNS}")
    seed = vary.get("sample_seed", 0)
    if method == "lhs":
        unit = qmc.LatinHypercube(d=len(params), seed=seed).random(n)
    else:
        import numpy as np

        unit = np.random.default_rng(seed).random((n, len(params)))
    lows, highs = [p["range"][0] for p in params], [p["range"][1] for p in params]
    scaled = qmc.scale(unit, lows, highs)
    return [dict(zip(names, map(float, row))) for row in scaled]


def run_id(controller: str, seed: int, parameters: dict, snapshot: str | None = None) -> str:
    what = {"controller": controller, "seed": seed, "parameters": parameters}
    if snapshot is not None:  # a branch: of which snapshot (its digest)
        what["snapshot"] = snapshot
    return hashlib.sha256(json.dumps(what, sort_keys=True).encode()).hexdigest()[:16]


# what a snapshot fixes: a branching campaign may not give these
_FIXED_BY_SNAPSHOT = ("scenario", "trajectory", "wind", "gusts", "allow_infeasible", "max_tilt")
TUNED_SEED = "sensors.seed"  # vary.seeds in a branching campaign: the sensors' noise after the snapshot


@dataclass(frozen=True)
class Branching:
    """The snapshot a campaign's cases branch from: its file, digest, time, stop time and loop options."""

    path: Path
    digest: str
    time: float
    stop: float | None
    options: dict  # LoopOptions.to_dict() of the run it was taken in
    controller: str  # dlqr, mixed, or the path of the user's controller FMU as the spec names it (never the snapshot)


def _branching(base: dict, path: Path) -> Branching:
    from ...engine import snapshot
    from ..case.options import snapshot_options
    from ..user_error import UserError

    given = [k for k in _FIXED_BY_SNAPSHOT if k in base]
    if given:
        raise SpecError(f"{path}: base.{given[0]}: a campaign from a snapshot runs the snapshot's loop (drop "
                        f"{', '.join('base.' + k for k in given)}; faults, tunable parameters, stop_time and seeds can vary)")
    file = (path.parent / base["snapshot"]).resolve()
    try:
        snap = snapshot.read(file)
        options = snapshot_options(snap.application, file)
    except (snapshot.SnapshotError, UserError) as err:
        raise SpecError(f"{path}: base.snapshot: {err}") from None
    if options.system is not None:
        raise SpecError(f"{path}: base.snapshot: {file} is of a --system run; campaigns branch from the thesis's loop")
    controllers = base.get("controllers")
    if options.controller_fmu is None:
        if controllers is not None:
            raise SpecError(f"{path}: base.controllers: a campaign from a snapshot runs the snapshot's loop (its controller "
                            f"is {options.controller}; drop base.controllers)")
        controller = options.controller
    else:  # a snapshot never says where a file is: the spec names the controller FMU, its digest is checked
        if controllers is None or len(controllers) != 1:
            raise SpecError(f"{path}: base.controllers: {file} was taken with the controller FMU {options.controller_fmu.name}: "
                            "name that one file in base.controllers (its digest is checked)")
        if not (path.parent / controllers[0]).is_file():
            raise SpecError(f"{path}: base.controllers: {controllers[0]} is not an existing controller FMU")
        controller = str((path.parent / controllers[0]).resolve())
    stop = snap.application.get("stop")
    if not (stop is None or (isinstance(stop, (int, float)) and not isinstance(stop, bool) and stop > 0)):
        raise SpecError(f"{path}: base.snapshot: its stop time is not a positive number of seconds")
    return Branching(file, hashlib.sha256(file.read_bytes()).hexdigest()[:16], snap.time, stop,
                     snap.application["options"], controller)


def _controller(name: str, path: Path) -> str:
    """A base.controllers entry as the runs name it: dlqr, mixed, or an FMU's absolute path (a class's .py file
    wrapped as `tiltload run --controller my_controller.py` wraps it: natively where it traces, cached by its source)."""
    if name in OUR_CONTROLLERS:
        return name
    file = (path.parent / name).resolve()
    if name.endswith(".py"):
        from ..wrap.class_fmu import controller_fmu_of_file
        from ..wrap.wrap import WrapError

        try:
            return str(controller_fmu_of_file(file, field=f"{path}: base.controllers"))
        except WrapError as err:
            raise SpecError(f"{path}: base.controllers: {err}") from None
    return str(file)


def load(path: Path) -> Campaign:
    """Read, validate and expand a campaign spec into its runs."""
    path = Path(path)
    data = read_spec_file(path)
    validate(data, path)
    base, vary, keep = data["base"], data["vary"], data.get("keep", {})
    if "snapshot" in base:
        return dataclasses.replace(_load_branches(data, path, _branching(base, path)), requirements=_requirements(keep, path))
    controllers = base.get("controllers", [DEFAULT_CONTROLLER])
    for c in controllers:
        if c not in OUR_CONTROLLERS and not (path.parent / c).is_file():
            raise SpecError(f"{path}: base.controllers: {c} is neither dlqr, mixed nor an existing controller FMU (or "
                            "a controller class's .py file)")
    named, controllers = controllers, [_controller(c, path) for c in controllers]
    wrapped = tuple((n, c) for n, c in zip(named, controllers) if n.endswith(".py"))
    seeds = vary.get("seeds", [DEFAULT_SEED])
    faults = checked_faults(base, _varied_targets(vary, path), path)
    targets = {p["name"]: p["targets"] for p in vary.get("parameters", [])}
    flight = read_flight(base, path)
    gust = dict(GUST_DEFAULTS) if any(t.startswith("gust.") for ts in targets.values() for t in ts) else None
    cases = []
    for point in _points(vary, path, len(controllers) * len(seeds)):
        values = [(target, value) for name, value in point.items() for target in targets[name]]
        parameters = resolve(values, base.get("parameters", {}), flight.trajectory.start, faults, gust)
        for controller in controllers:
            for seed in seeds:
                cases.append(Case(run_id(controller, seed, parameters), controller, seed, point, dict(parameters)))
    ids = [c.run_id for c in cases]
    if len(set(ids)) != len(ids):
        raise SpecError(f"{path}: the spec describes the same run twice (repeated values?)")
    return Campaign(data["name"], base.get("scenario", DEFAULT_SCENARIO), flight, base.get("stop_time"),
                    base.get("gusts", GUSTS), tuple(keep.get("metrics", METRICS)), keep.get("logs", False), faults,
                    list(targets), cases, path, requirements=_requirements(keep, path), wrapped=wrapped)


def _varied_targets(vary: dict, path: Path) -> list[tuple[str, str]]:
    """(where, target) of every varied target, each checked against the grammar (case/targets.py); a mission's
    waypoints are a search's to move (a campaign's runs share one reference)."""
    out = []
    for p in vary.get("parameters", []):
        for target in p["targets"]:
            where = f"vary.parameters.{p['name']}"
            problem = kind_problem(target) or ("a campaign's runs fly one reference: waypoints.K.* is a search's "
                                               "(tiltload falsify)" if target.startswith("waypoints.") else None)
            if problem:
                raise SpecError(f"{path}: {where}: {problem}")
            out.append((where, target))
    return out


def _requirements(keep: dict, path: Path) -> tuple:
    """keep.requirements: a requirement file (relative to the spec): each (name, STL), its columns' names checked."""
    if "requirements" not in keep:
        return ()
    from ...engine.requirement.files import RequirementError
    from ...engine.requirement.files import load as load_requirements

    try:
        reqs = load_requirements(path.parent / keep["requirements"])
    except RequirementError as err:
        raise SpecError(f"{path}: keep.requirements: {err}") from None
    for r in reqs:
        if not re.match(r"^[A-Za-z_]\w*$", r.name):
            raise SpecError(f"{path}: keep.requirements: requirement '{r.name}' names a column: letters, digits and _ only")
    return tuple((r.name, r.text) for r in reqs)


def _load_branches(data: dict, path: Path, branching: Branching) -> Campaign:
    """The cases of a campaign from a snapshot: its loop, each case's faults, tunable parameters and seed."""
    from ....scenario_fmu.choice import Trajectory
    from ..loop.inputs import trajectory as as_trajectory

    base, vary, keep = data["base"], data["vary"], data.get("keep", {})
    options = branching.options  # the snapshot's LoopOptions.to_dict()
    stop = base.get("stop_time") or branching.stop
    if stop is None or stop <= branching.time:
        raise SpecError(f"{path}: base.stop_time: {stop} s is not after the snapshot's time ({branching.time:g} s)")
    # None: the run's own faults, as --from-snapshot
    faults = checked_faults(base, _varied_targets(vary, path), path) if "faults" in base else None
    targets = {p["name"]: p["targets"] for p in vary.get("parameters", [])}
    for name, these in targets.items():
        if TUNED_SEED in these and "seeds" in vary:
            raise SpecError(f"{path}: vary.parameters.{name}: {TUNED_SEED} is what vary.seeds sets")
    controller = branching.controller
    seeds = vary.get("seeds")
    cases = []
    for point in _points(vary, path, len(seeds or [options["seed"]])):
        for seed in seeds or [options["seed"]]:
            parameters = dict(base.get("parameters", {}))
            for name, value in point.items():
                for target in targets[name]:
                    parameters[target] = value
            if seeds:
                parameters[TUNED_SEED] = seed
            cases.append(Case(run_id(controller, seed, parameters, branching.digest), controller, seed, point, parameters))
    ids = [c.run_id for c in cases]
    if len(set(ids)) != len(ids):
        raise SpecError(f"{path}: the spec describes the same run twice (repeated values?)")
    reference = options.get("reference")
    flight = Flight(Trajectory.from_dict(reference) if reference else as_trajectory(options["trajectory"]))
    return Campaign(data["name"], options["scenario"], flight, stop, options["gusts"], tuple(keep.get("metrics", METRICS)),
                    keep.get("logs", False), faults, list(targets), cases, path, branching.path, branching.time)


def kept_requirements(spec: dict | None, spec_folder: Path | None) -> list:
    """A spec's keep.requirements file, loaded (a report's sources and formulas), or none where it is no longer there."""
    from ...engine.requirement.files import RequirementError, load

    name = (spec or {}).get("keep", {}).get("requirements")
    path = Path(spec_folder or ".") / name if name else None
    try:
        return load(path) if path is not None and path.is_file() else []
    except RequirementError:
        return []

"""The options of a run of the loop, resolved once into a frozen value (the system they describe: system.py, the one builder)."""

from __future__ import annotations

import argparse
from dataclasses import asdict, dataclass, fields
from pathlib import Path

from ....scenario_fmu.choice import THESIS, Trajectory
from ..loop.defaults import FMU_DIR as DEFAULT_FMU_DIR
from ..loop.defaults import MAX_TILT, OUR_CONTROLLERS
from ..loop.defaults import SCENARIO as DEFAULT_SCENARIO
from ..loop.defaults import SEED as DEFAULT_SEED
from ..loop.defaults import VEHICLE as DEFAULT_VEHICLE
from ..loop.inputs import trajectory as as_trajectory
from ..loop.thesis import LOOPS
from ..user_error import UserError

# the options that describe the thesis's loop, which a system file describes itself: given with --system, an error
LOOP_ONLY = (("vehicle", "--vehicle"), ("scenario", "--scenario"), ("trajectory", "--trajectory"),
             ("controller", "--controller"), ("seed", "--seed"), ("delay", "--delay"), ("no_gusts", "--no-gusts"),
             ("fmus", "--fmus"), ("allow_unknown_inputs", "--allow-unknown-inputs"), ("fmi", "--fmi"),
             ("clocks", "--clocks"))


_PATH = {"type": ["string", "null"], "maxLength": 4096}
_NUMBER = {"type": "number"}
# LoopOptions.to_dict() as a snapshot keeps it (application.options): checked before a continued run or a campaign uses it
OPTIONS_SCHEMA = {
    "type": "object", "additionalProperties": False,
    "required": ["vehicle", "scenario", "trajectory", "controller", "controller_fmu", "seed", "stop_time", "delay", "gusts",
                 "faults", "settings", "system", "fmus", "allow_unknown_inputs", "reference", "wind", "allow_infeasible",
                 "max_tilt", "allow_external_fmus", "remotes", "fmi", "clocks"],
    "properties": {
        "vehicle": {"enum": sorted(LOOPS)}, "scenario": {"enum": ["fsi", "lkf", "zse"]},
        "trajectory": {"type": ["integer", "string"]}, "controller": {"type": "string", "minLength": 1, "maxLength": 4096},
        "controller_fmu": _PATH, "seed": {"type": "integer", "minimum": 0, "maximum": 2**31 - 1},
        "stop_time": {"type": ["number", "null"], "exclusiveMinimum": 0}, "delay": {"type": "boolean"},
        "gusts": {"type": "boolean"}, "faults": _PATH, "system": _PATH, "fmus": _PATH, "wind": _PATH,
        "settings": {"type": "array", "items": {"type": "array", "minItems": 2, "maxItems": 2, "prefixItems": [{"type": "string"}]}},
        "allow_unknown_inputs": {"type": "boolean"}, "allow_infeasible": {"type": "boolean"},
        "allow_external_fmus": {"type": "boolean"}, "clocks": {"type": "boolean"}, "fmi": {"enum": [2, 3]},
        "max_tilt": {"type": "number", "exclusiveMinimum": 0, "maximum": 180},
        "step": {"type": ["number", "null"], "exclusiveMinimum": 0, "maximum": 3600},  # not required: older snapshots
        "start_time": {"type": ["number", "null"], "minimum": 0, "maximum": 1e9},  # not required: older snapshots
        "input_files": {"type": "array", "items": {"type": "array", "minItems": 2, "maxItems": 2,
                                                   "items": {"type": "string"}}},
        "remotes": {"type": "array", "items": {"type": "array", "minItems": 2, "maxItems": 2, "items": {"type": "string"}}},
        "reference": {"oneOf": [{"type": "null"}, {
            "type": "object", "additionalProperties": False, "required": ["label", "code", "settings", "start", "duration"],
            "properties": {"label": {"type": "string"}, "code": {"type": "integer"}, "source": {"type": "string"},
                           "settings": {"type": "array", "items": {"type": "array", "minItems": 2, "maxItems": 2,
                                                                   "prefixItems": [{"type": "string"}, _NUMBER]}},
                           "start": {"type": "array", "minItems": 3, "maxItems": 3, "items": _NUMBER},
                           "duration": {"type": "number", "exclusiveMinimum": 0},
                           # a waypoint mission's knot table (scenario_fmu.waypoints: KNOT_COLUMNS, MAX_WAYPOINTS)
                           "knots": {"type": "array", "maxItems": 10_000,
                                     "items": {"type": "array", "minItems": 13, "maxItems": 13, "items": _NUMBER}}}}]},
    },
}


def snapshot_options(application: dict, where) -> LoopOptions:
    """The loop options a snapshot was taken with, checked against OPTIONS_SCHEMA (one line naming the first problem)."""
    from ...engine.user_files import schema_problem

    options = application.get("options")
    if options is None:
        raise UserError(f"{where} was not taken by `tiltload run` (it names no loop options)")
    problem = schema_problem(options, OPTIONS_SCHEMA, top="(all)", limit=160)
    if problem:
        raise UserError(f"{where}: its loop options are not a run's: options.{problem}")
    opts = LoopOptions.from_dict(options)
    ref = opts.reference
    if ref is not None and opts.trajectory != (ref.code if ref.code in THESIS else ref.label):
        raise UserError(f"{where}: its loop options disagree (trajectory {opts.trajectory!r}, reference {ref.label!r}): "
                        "edited, not taken by tiltload run")
    return opts


@dataclass(frozen=True, kw_only=True)
class LoopOptions:
    """What describes one run of the loop (or of a system file), with every default filled in; built by keyword."""

    vehicle: str
    scenario: str
    trajectory: int | str  # 0-3, or the label of a shape or file (reference)
    controller: str  # dlqr, mixed, or the path of a controller FMU
    controller_fmu: Path | None  # the user's controller FMU, if controller is one
    seed: int
    stop_time: float | None  # None: the trajectory's duration (or the package's)
    delay: bool
    gusts: bool
    faults: Path | None
    settings: tuple[tuple[str, object], ...]  # --set INSTANCE.NAME=VALUE, in order
    system: Path | None  # a system file instead of the loop
    fmus: Path  # the FMU folder of the FMI 2.0 set (the FMI 3.0 set is in fmus/fmi3/)
    allow_unknown_inputs: bool
    reference: Trajectory | None = None  # what the scenario FMU flies (None: the thesis's trajectory)
    wind: Path | None = None  # a wind file (scenario_fmu.wind)
    allow_infeasible: bool = False
    max_tilt: float = MAX_TILT  # degrees, the feasibility check's
    allow_external_fmus: bool = False  # a system file's FMUs may lie outside its package or folder
    remotes: tuple[tuple[str, str], ...] = ()  # --remote INSTANCE=HOST:PORT, in order (where, not which loop)
    fmi: int = 2  # the FMI version of the loop's FMUs (the FMI 2.0 set in fmus/, the FMI 3.0 set in fmus/fmi3/)
    clocks: bool = False  # FMI 3.0: the sensors and the controller with clocks
    step: float | None = None  # --step: the step of a system package that declares none (s)
    start_time: float | None = None  # --start-time: the time a system starts at (None: its file's)
    input_files: tuple[tuple[str, str], ...] = ()  # --input-file INSTANCE=FILE, in order
    # a case set's wind, read once for all its runs (the scenario FMU's parameters); a run's own is its wind file
    wind_parameters: tuple[tuple[str, object], ...] = ()

    @property
    def controller_label(self) -> str:
        return self.controller_fmu.stem if self.controller_fmu else self.controller

    def to_dict(self) -> dict:
        """JSON-able, for a snapshot to say which loop it is of."""
        d = {f.name: getattr(self, f.name) for f in fields(self) if f.name != "wind_parameters"}
        for key in ("controller_fmu", "faults", "system", "fmus", "wind"):
            d[key] = None if d[key] is None else str(Path(d[key]).resolve())
        d["settings"] = [list(s) for s in self.settings]
        d["remotes"] = [list(r) for r in self.remotes]
        d["input_files"] = [[name, str(Path(f).resolve())] for name, f in self.input_files]
        d["reference"] = None if self.reference is None else asdict(self.reference)
        return d

    @classmethod
    def from_dict(cls, d: dict) -> LoopOptions:
        d = dict(d)
        for key in ("controller_fmu", "faults", "system", "fmus", "wind"):
            d[key] = None if d[key] is None else Path(d[key])
        d["settings"] = tuple(tuple(s) for s in d["settings"])
        d["remotes"] = tuple(tuple(r) for r in d.get("remotes", ()))
        d["input_files"] = tuple(tuple(r) for r in d.get("input_files", ()))
        r = d["reference"]
        d["reference"] = None if r is None else Trajectory.from_dict(r)
        return cls(**d)

    def run_name(self, default_stop_time: float | None = None) -> str:
        """The default name of the run's log: what sets this run apart, so two different runs do not share a log.
        The loop: vehicle, scenario, trajectory, controller, seed; then each of the delay, calm air, the FMI version, the
        wind file, the faults file, the remote instances, the --set values and a stop time other than default_stop_time,
        when given. (What `tiltload run` adds of its own: log_name.default_log_name.)"""
        if self.system is not None:
            parts = [self.system.stem]
        else:
            parts = [f"{'uav_' if self.vehicle == 'uav' else ''}{self.scenario}_traj{self.trajectory}_"
                     f"{self.controller_label}_seed{self.seed}"]
            parts += ["delay"] * self.delay + ["calm"] * (not self.gusts)
            parts += ["fmi3" + "_clocks" * self.clocks] * (self.fmi == 3)
            if self.wind is not None:
                parts.append(f"wind-{self.wind.stem}")
        if self.faults is not None:
            parts.append(f"faults-{self.faults.stem}")
        if self.remotes:  # another machine's build of an FMU may round otherwise
            parts.append("remote-" + "-".join(name for name, _ in self.remotes))
        if self.settings:
            parts.append("set-" + _settings_tag(self.settings))
        if self.step is not None:
            parts.append(f"step{self.step:g}s")
        if self.start_time is not None:
            parts.append(f"start{self.start_time:g}s")
        if self.input_files:
            parts.append("inputs-" + "-".join(Path(f).stem for _, f in self.input_files))
        if self.stop_time is not None and self.stop_time != default_stop_time:
            parts.append(f"t{self.stop_time:g}s")
        return file_safe("_".join(parts))


def _settings_tag(settings) -> str:
    """--set values in a file name: readable while short (plant.m_L=0.2-plant.l=0.7), else a digest of them."""
    import hashlib

    text = "-".join(f"{k}={v}" for k, v in settings)
    return text if len(text) <= 40 else hashlib.sha256(text.encode()).hexdigest()[:10]


def file_safe(name: str) -> str:
    import re

    return re.sub(r"[^A-Za-z0-9._=+-]", "_", name)


def resolve_loop(args: argparse.Namespace) -> LoopOptions:
    """The loop options of a command line, checked against the vehicle's choices. With --system, the loop's own
    options are refused (one line naming them): the system file describes its run itself."""
    fmi, clocks = getattr(args, "fmi", None) or 2, getattr(args, "clocks", False)
    if clocks and fmi != 3:
        raise UserError("--clocks: clocks are FMI 3.0's; add --fmi 3")
    if args.system is not None:
        given = [flag for attr, flag in LOOP_ONLY if getattr(args, attr, None) not in (None, False, [], ())]
        if given:
            one = len(given) == 1
            raise UserError(f"--system {args.system} runs the system as its file describes it: {', '.join(given)} "
                            f"{'applies' if one else 'apply'} to the thesis's loop only (drop {'it' if one else 'them'}, "
                            "or set it in the system file)")
        load = LOOPS[DEFAULT_VEHICLE]  # unused by a system file but for the stop time a JSON description may lack (the loop's)
        return LoopOptions(vehicle=DEFAULT_VEHICLE, scenario=DEFAULT_SCENARIO, trajectory=load.default_trajectory,
                           controller=load.default_controller, controller_fmu=None, seed=DEFAULT_SEED, stop_time=args.stop_time,
                           delay=False, gusts=True, faults=args.faults, settings=tuple(getattr(args, "set", None) or ()),
                           system=args.system, fmus=DEFAULT_FMU_DIR,
                           allow_unknown_inputs=False, allow_external_fmus=getattr(args, "allow_external_fmus", False),
                           remotes=tuple(getattr(args, "remote", ())), step=getattr(args, "step", None),
                           start_time=getattr(args, "start_time", None), input_files=tuple(getattr(args, "input_file", ())))
    if getattr(args, "step", None) is not None:
        raise UserError("--step is for --system (an SSP package that declares no step); the loop's tick is its own")
    if getattr(args, "start_time", None) is not None:
        raise UserError("--start-time is for --system: the loop runs from t = 0 (its trajectory, faults and snapshots count "
                        "time from there)")
    if getattr(args, "input_file", ()):
        raise UserError("--input-file is for --system: the loop's inputs are its own FMUs' outputs")
    if getattr(args, "allow_external_fmus", False):
        raise UserError("--allow-external-fmus is for --system (a package's FMUs); the loop's FMUs are built into --fmus")
    vehicle = args.vehicle or DEFAULT_VEHICLE
    loop = LOOPS[vehicle]
    reference = as_trajectory(loop.default_trajectory if args.trajectory is None else args.trajectory)
    trajectory = reference.code if reference.code in THESIS else reference.label
    controller = loop.default_controller if args.controller is None else args.controller
    scenario = args.scenario or DEFAULT_SCENARIO
    if reference.code in THESIS and trajectory not in loop.trajectories:
        raise UserError(f"--trajectory {trajectory}: the {vehicle} vehicle has trajectories "
                        f"{', '.join(map(str, loop.trajectories))}")
    if scenario not in loop.scenarios:
        raise UserError(f"--scenario {scenario}: the {vehicle} vehicle has {', '.join(loop.scenarios)}")
    if controller in OUR_CONTROLLERS and controller not in loop.controllers:
        raise UserError(f"--controller {controller}: the {vehicle} vehicle has {', '.join(loop.controllers)} "
                        "(or your own FMU)")
    controller_fmu = None
    if controller not in OUR_CONTROLLERS:
        controller_fmu = Path(controller)
        if not controller_fmu.is_file():
            raise UserError(f"--controller: {controller_fmu} is neither dlqr, mixed nor an existing FMU file")
    seed = DEFAULT_SEED if args.seed is None else args.seed
    return LoopOptions(vehicle=vehicle, scenario=scenario, trajectory=trajectory, controller=controller,
                       controller_fmu=controller_fmu, seed=seed, stop_time=args.stop_time, delay=args.delay, gusts=not args.no_gusts,
                       faults=args.faults, settings=tuple(args.set), system=None, fmus=args.fmus or DEFAULT_FMU_DIR,
                       allow_unknown_inputs=args.allow_unknown_inputs, reference=reference, wind=args.wind,
                       allow_infeasible=args.allow_infeasible, max_tilt=args.max_tilt, remotes=tuple(getattr(args, "remote", ())),
                       fmi=fmi, clocks=clocks)

"""The one builder of a case's system, whatever asks for it: a run (`tiltload run`, `tl.run`), a campaign case, a branch
from a snapshot and a search point are `build_system` with different values. It makes the thesis's loop (its FMUs built
when stale, the user's controller checked, parameters set, faults added, the reference checked before the first step)
or the system a --system file describes."""

from __future__ import annotations

import dataclasses
import sys
from dataclasses import dataclass
from pathlib import Path

from ..loop.thesis import CONTROLLER, default_stop, default_system, set_parameters
from ..user_error import UserError
from .flight import LoopBase, flight_of
from .options import LoopOptions
from .targets import instance_settings, with_fault_fields


@dataclass
class LoopSystem:
    """The system to run, its stop time, and the schedule it asks for (None: ours, ordered)."""

    system: object  # engine.system.System
    stop: float
    schedule: str | None
    natural_stop: float  # the stop time without --stop-time: the trajectory's duration, or the package's


def build_system(opts: LoopOptions, unpack_into: Path | None = None, *, faults: list | None = None, settings: dict | None = None,
                 prepared: bool = False, build: bool = True, say=print) -> LoopSystem:
    """The system the options describe: the thesis's loop (FMUs built when stale), with the user's controller FMU,
    parameters set and faults added; or the system a --system file describes (SSP packages unpacked into unpack_into).
    faults: the faults' JSON form (a case set's, varied), in place of opts.faults' file; settings: FMU parameters
    {instance.name: value} after opts.settings. prepared: the FMUs are built and the reference was checked already (a
    case set's runs, a branch from a snapshot). build: build what is stale (a run continued from a snapshot builds
    nothing: it runs the build the snapshot was taken with). say: where the feasibility check's summary and notes go
    (the build's progress goes to stderr)."""
    from ...engine.faults.parse import load as load_faults
    from ...engine.faults.parse import parse
    from ..loop.fmus import build_all, fmu_folder

    if opts.system is not None:
        system, stop, schedule = read_system(opts.system, unpack_into, opts.allow_external_fmus, say, opts.step)
        if opts.start_time is not None:  # --start-time over the file's (an SSD's DefaultExperiment, a JSON "start_time")
            system.start_time = float(opts.start_time)
        set_parameters(system, dict(opts.settings))  # --set over the file's values, checked by the engine's type table
        for name, table in opts.input_files:  # --input-file over the file's own (engine/inputs.py reads and checks it)
            system.instance(name).input_file = Path(table).resolve()
    else:
        folder = fmu_folder(opts.fmus, opts.fmi)
        if not prepared and build:
            build_all(folder, progress=lambda m: print(m, file=sys.stderr), vehicles=(opts.vehicle,),  # says what it builds
                      fmi_version=opts.fmi, clocked=opts.clocks)
        system = default_system(folder, opts.scenario, opts.reference or opts.trajectory,
                                opts.controller if opts.controller_fmu is None else None, opts.seed, opts.controller_fmu,
                                opts.delay, opts.gusts, opts.vehicle, _wind(opts), opts.fmi, opts.clocks)
        set_parameters(system, dict(opts.settings))
        if settings:
            set_parameters(system, settings)
        if not prepared:
            from ..loop.parameter_types import check_settings

            check_settings(system, opts.settings)
        if opts.controller_fmu is not None and not prepared:
            from ...engine.fmi.model_description import read_fmu
            from ..loop.ports import check_controller

            check_controller(read_fmu(opts.controller_fmu, CONTROLLER), opts.allow_unknown_inputs, opts.vehicle)
        stop, schedule = None, None
    for name, address in opts.remotes:
        system.instance(name).remote = address
    if faults is not None:
        system.faults = [*system.faults, *parse(faults)] if faults else system.faults
    elif opts.faults is not None:
        system.faults = [*system.faults, *load_faults(opts.faults)]
    natural = stop or default_stop(opts.reference or opts.trajectory)
    stop = opts.stop_time or natural
    if system.start_time and stop <= system.start_time:  # FMPy's rule: the stop time is a time, not a duration
        raise UserError(f"stop time {stop:g} s: the system starts at {system.start_time:g} s, and its stop time is an "
                        "absolute time after that")
    if opts.system is None and not prepared:
        from ..feasibility.policy import enforce

        enforce(system, stop, opts.allow_infeasible, opts.max_tilt, say)  # before the first step: refuses what cannot be flown
    return LoopSystem(system, stop, schedule, natural)


def _wind(opts: LoopOptions) -> dict | None:
    """The scenario FMU's wind parameters: a case set's (read once for all its runs), else the run's wind file's."""
    if opts.wind_parameters:
        return dict(opts.wind_parameters)
    if opts.wind is not None:
        from ..loop.inputs import read_wind

        return read_wind(opts.wind)
    return None


def case_options(fmu_dir: Path, base: LoopBase, controller: str, seed: int) -> LoopOptions:
    """The loop options of one run of a case set (a campaign's base or a search's) with its controller and seed."""
    from ....scenario_fmu.choice import THESIS
    from ..loop.defaults import OUR_CONTROLLERS, VEHICLE

    flight = flight_of(base)
    is_fmu = controller not in OUR_CONTROLLERS
    reference = flight.trajectory
    return LoopOptions(vehicle=VEHICLE, scenario=base.scenario, trajectory=reference.code if reference.code in THESIS
                       else reference.label, controller=controller, controller_fmu=Path(controller) if is_fmu else None,
                       seed=seed, stop_time=base.stop_time, delay=False, gusts=base.gusts, faults=None, settings=(), system=None,
                       fmus=Path(fmu_dir), allow_unknown_inputs=False, reference=reference, wind_parameters=flight.wind,
                       allow_infeasible=flight.allow_infeasible, max_tilt=flight.max_tilt)


def case_system(fmu_dir: Path, base: LoopBase, controller: str, seed: int, parameters: dict):
    """The loop of a case set's base (scenario, trajectory, gusts, faults) with a run's controller, seed and parameters
    (the grammar's instance.name and faults.N.field keys: targets.py)."""
    return build_system(case_options(fmu_dir, base, controller, seed), faults=with_fault_fields(base.faults or [], parameters),
                        settings=instance_settings(parameters), prepared=True).system


def branch_system(fmu_dir: Path, snap, faults, parameters: dict, controller: str):
    """The system a snapshot was taken of (its loop options, the FMUs of fmu_dir, the controller the spec names: a
    snapshot never says where a file is), with a case's faults (None: the run's own) and the snapshot's settings for
    its tunable parameters."""
    from .options import snapshot_options

    opts = dataclasses.replace(snapshot_options(snap.application, "base.snapshot"), fmus=fmu_dir)
    if opts.controller_fmu is not None:
        opts = dataclasses.replace(opts, controller=controller, controller_fmu=Path(controller))
    if faults is not None:
        opts = dataclasses.replace(opts, faults=None)
        faults = with_fault_fields(faults, parameters)
    system = build_system(opts, fmu_dir, faults=faults, prepared=True).system
    settings: dict[str, dict] = {}
    for key, value in instance_settings(parameters).items():
        instance, _, name = key.partition(".")
        settings.setdefault(instance, {})[name] = value
    return system, dataclasses.replace(snap, settings=settings)


def read_system(path: Path, unpack_into: Path, allow_external_fmus: bool = False, say=None, step: float | None = None):
    """A system file: an SSP package (.ssp, or a bare .ssd) or a JSON description; (system, stop or None, schedule).
    say: where a standard package's step rule is told (ssp/load.py); step: --step, for a package that declares none."""
    from ...engine import system as sysdesc
    from ...engine.ssp.load import load

    if path.suffix.lower() in (".ssp", ".ssd"):
        return load(path, unpack_into, allow_external=allow_external_fmus, say=say, step=step)
    if step is not None:
        raise UserError(f"--step: {path} declares its tick (a JSON description's \"tick\"); --step is for an SSP package "
                        "that declares no step")
    if allow_external_fmus:
        raise UserError(f"--allow-external-fmus is for SSP packages (.ssp/.ssd); {path} is a JSON description, "
                        "whose FMU paths are the user's own")
    return sysdesc.load(path), None, None

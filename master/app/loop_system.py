"""The system a run's options describe: the thesis's loop (its FMUs built when stale, the user's controller checked,
parameters set, faults added, the reference checked before the first step) or the system a --system file describes."""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path

from .loop import CONTROLLER, default_stop, default_system, set_parameters
from .options import LoopOptions
from .user_error import UserError


@dataclass
class LoopSystem:
    """The system to run, its stop time, and the schedule it asks for (None: ours, ordered)."""

    system: object  # engine.system.System
    stop: float
    schedule: str | None
    natural_stop: float  # the stop time without --stop-time: the trajectory's duration, or the package's


def loop_system(opts: LoopOptions, unpack_into: Path, prepared: bool = False, build: bool = True, say=print) -> LoopSystem:
    """The system the options describe: the thesis's loop (FMUs built when stale), with the user's controller FMU,
    parameters set and faults added; or the system a --system file describes (SSP packages unpacked into unpack_into).
    prepared: the FMUs are built and the reference was checked already (a campaign's branches from a snapshot). build:
    build what is stale (a run continued from a snapshot builds nothing: it runs the build the snapshot was taken with).
    say: where the feasibility check's summary and notes go (the build's progress goes to stderr)."""
    from ..engine.faults.parse import load as load_faults
    from .fmus import build_all, fmu_folder

    if opts.system is not None:
        system, stop, schedule = read_system(opts.system, unpack_into, opts.allow_external_fmus)
    else:
        folder = fmu_folder(opts.fmus, opts.fmi)
        if not prepared and build:
            build_all(folder, progress=lambda m: print(m, file=sys.stderr), vehicles=(opts.vehicle,),  # says what it builds
                      fmi_version=opts.fmi, clocked=opts.clocks)
        from .inputs import read_wind

        system = default_system(folder, opts.scenario, opts.reference or opts.trajectory,
                                opts.controller if opts.controller_fmu is None else None, opts.seed, opts.controller_fmu,
                                opts.delay, opts.gusts, opts.vehicle, read_wind(opts.wind) if opts.wind else None,
                                opts.fmi, opts.clocks)
        set_parameters(system, dict(opts.settings))
        if not prepared:
            from .parameter_types import check_settings

            check_settings(system, opts.settings)
        if opts.controller_fmu is not None and not prepared:
            from ..engine.fmi.model_description import read_fmu
            from .ports import check_controller

            check_controller(read_fmu(opts.controller_fmu, CONTROLLER), opts.allow_unknown_inputs, opts.vehicle)
        stop, schedule = None, None
    for name, address in opts.remotes:
        system.instance(name).remote = address
    if opts.faults is not None:
        system.faults = [*system.faults, *load_faults(opts.faults)]
    natural = stop or default_stop(opts.reference or opts.trajectory)
    stop = opts.stop_time or natural
    if opts.system is None and not prepared:
        from .feasibility import enforce

        enforce(system, stop, opts.allow_infeasible, opts.max_tilt, say)  # before the first step: refuses what cannot be flown
    return LoopSystem(system, stop, schedule, natural)


def read_system(path: Path, unpack_into: Path, allow_external_fmus: bool = False):
    """A system file: an SSP package (.ssp, or a bare .ssd) or a JSON description; (system, stop or None, schedule)."""
    from ..engine import system as sysdesc
    from ..engine.ssp.load import load

    if path.suffix.lower() in (".ssp", ".ssd"):
        return load(path, unpack_into, allow_external=allow_external_fmus)
    if allow_external_fmus:
        raise UserError(f"--allow-external-fmus is for SSP packages (.ssp/.ssd); {path} is a JSON description, "
                        "whose FMU paths are the user's own")
    return sysdesc.load(path), None, None

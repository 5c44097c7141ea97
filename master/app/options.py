"""The options of a run of the loop, resolved once into a frozen value, and the system they describe."""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from pathlib import Path

from .errors import UserError
from .loop import CONTROLLER, LOOPS, default_stop, default_system, set_parameters


@dataclass(frozen=True)
class LoopOptions:
    """What describes one run of the loop (or of a system file), with every default filled in."""

    vehicle: str
    scenario: str
    trajectory: int
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
    fmi: int = 2  # the FMI version of the loop's FMUs
    clocks: bool = False  # FMI 3.0: the sensors and the controller with clocks

    @property
    def controller_label(self) -> str:
        return self.controller_fmu.stem if self.controller_fmu else self.controller


def resolve_loop(args: argparse.Namespace) -> LoopOptions:
    """The loop options of a command line, checked against the vehicle's choices."""
    loop = LOOPS[args.vehicle]
    trajectory = loop.default_trajectory if args.trajectory is None else args.trajectory
    controller = loop.default_controller if args.controller is None else args.controller
    if trajectory not in loop.trajectories:
        raise UserError(f"--trajectory {trajectory}: the {args.vehicle} vehicle has trajectories "
                        f"{', '.join(map(str, loop.trajectories))}")
    if args.scenario not in loop.scenarios:
        raise UserError(f"--scenario {args.scenario}: the {args.vehicle} vehicle has {', '.join(loop.scenarios)}")
    if controller in ("dlqr", "mixed") and controller not in loop.controllers:
        raise UserError(f"--controller {controller}: the {args.vehicle} vehicle has {', '.join(loop.controllers)} "
                        "(or your own FMU)")
    fmi, clocks = getattr(args, "fmi", 2), getattr(args, "clocks", False)
    if clocks and fmi != 3:
        raise UserError("--clocks: clocks are FMI 3.0's; add --fmi 3")
    if args.system is not None and (fmi != 2 or clocks):
        raise UserError("--fmi and --clocks choose the loop's FMUs; a --system file names its own (and may give each "
                        "instance's FMI version, \"fmi\": 3)")
    controller_fmu = None
    if controller not in ("dlqr", "mixed"):
        controller_fmu = Path(controller)
        if not controller_fmu.is_file():
            raise UserError(f"--controller: {controller_fmu} is neither dlqr, mixed nor an existing FMU file")
    return LoopOptions(args.vehicle, args.scenario, trajectory, controller, controller_fmu, args.seed, args.stop_time,
                       args.delay, not args.no_gusts, args.faults, tuple(args.set), args.system, args.fmus,
                       args.allow_unknown_inputs, fmi, clocks)


@dataclass
class LoopSystem:
    """The system to run, its stop time, and the schedule it asks for (None: ours, ordered)."""

    system: object  # engine.system.System
    stop: float
    schedule: str | None


def loop_system(opts: LoopOptions, unpack_into: Path) -> LoopSystem:
    """The system the options describe: the thesis's loop (FMUs built when stale), with the user's controller FMU,
    parameters set and faults added; or the system a --system file describes (SSP packages unpacked into unpack_into)."""
    from ..engine.manipulators import load as load_faults
    from .fmus import build_all, fmu_folder

    if opts.system is not None:
        system, stop, schedule = read_system(opts.system, unpack_into)
    else:
        folder = fmu_folder(opts.fmus, opts.fmi)
        results = build_all(folder, progress=lambda m: print(m, file=sys.stderr), vehicles=(opts.vehicle,), fmi_version=opts.fmi,
                            clocked=opts.clocks)
        rebuilt = [r.path.name for r in results if r.rebuilt]
        if rebuilt:
            print(f"built {', '.join(rebuilt)} into {folder}/")
        system = default_system(folder, opts.scenario, opts.trajectory, opts.controller if opts.controller_fmu is None else None,
                                opts.seed, opts.controller_fmu, opts.delay, opts.gusts, opts.vehicle, opts.fmi, opts.clocks)
        set_parameters(system, dict(opts.settings))
        if opts.controller_fmu is not None:
            from ..engine.model_description import read_fmu
            from .ports import check_controller

            check_controller(read_fmu(opts.controller_fmu, CONTROLLER), opts.allow_unknown_inputs, opts.vehicle)
        stop, schedule = None, None
    if opts.faults is not None:
        system.faults = [*system.faults, *load_faults(opts.faults)]
    stop = opts.stop_time or stop or default_stop(opts.trajectory)
    return LoopSystem(system, stop, schedule)


def read_system(path: Path, unpack_into: Path):
    """A system file: an SSP package (.ssp, or a bare .ssd) or a JSON description; (system, stop or None, schedule)."""
    from ..engine import ssp
    from ..engine import system as sysdesc

    if path.suffix.lower() in (".ssp", ".ssd"):
        return ssp.load(path, unpack_into)
    return sysdesc.load(path), None, None

"""`tiltload run`: the main job. Build what is stale, run the loop (or a system file), log, score, plot."""

from __future__ import annotations

import argparse
from pathlib import Path

from .. import arguments


def add_parser(sub) -> None:
    r = sub.add_parser("run", help="main job: run the closed loop through the FMUs, log to MCAP, print ISE/IADU, plot")
    arguments.add_loop_options(r)
    r.add_argument("--schedule", choices=("ordered", "jacobi"), default=None,
                   help="ordered: tiltload's master (default); jacobi: as libcosim and Ecos step (a package's own choice "
                        "is the default for it)")
    r.add_argument("--out", type=Path, default=Path("runs"), help="where the log and plots go (default: runs)")
    r.add_argument("--name", type=arguments.file_stem, default=None, help="file name stem of the log")
    r.add_argument("--trust-fmus", action="store_true",
                   help="run every FMU inside this process (default: FMUs tiltload did not build run each in its own "
                        "process, so a crash, exit() or hang in one ends the run with one line)")
    r.add_argument("--step-timeout", type=arguments.positive_time, default=None, metavar="S",
                   help="watchdog for an FMU in its own process: the longest a call may take (default 10 s)")
    r.add_argument("--no-plots", action="store_true", help="skip the PNG figures")
    r.add_argument("--no-log", action="store_true", help="no MCAP log: metrics only (campaigns); implies --no-plots")
    r.add_argument("--log-every", type=arguments.whole_number, default=1, metavar="N",
                   help="log every N-th step of each FMU (default 1: every step)")
    r.add_argument("--quiet", action="store_true", help="no progress bar")
    r.set_defaults(func=run)


def _announce(execution) -> None:
    """Before the first step: the inputs nothing feeds (a misspelt port shows up here)."""
    if execution.unconnected:
        print(f"unconnected inputs, held for the whole run: {', '.join(execution.unconnected)}")


def run(args: argparse.Namespace) -> int:
    from ....controller_fmu.design.cache import cache_root
    from ...engine import jacobi
    from ...engine.model_description import read_fmu
    from ...engine.run import run_system
    from ..errors import run_failed
    from ..fmus import is_foreign
    from ..loop import is_loop, loop_metrics
    from ..options import loop_system, resolve_loop
    from ..plot import plot_run
    from ..scene import scene_channels

    opts = resolve_loop(args)
    loop = loop_system(opts, cache_root() / "ssp")
    system, stop = loop.system, loop.stop
    schedule = args.schedule or loop.schedule
    if schedule == "jacobi":
        system = jacobi.explicit(system, {i.name: read_fmu(i.fmu, i.name) for i in system.instances}, jacobi=True)
        print("schedule: jacobi (every output reaches its inputs one step late, as libcosim and Ecos pass them)")
    label = args.name or (opts.system.stem if opts.system is not None else
                          f"{'uav_' if opts.vehicle == 'uav' else ''}{opts.scenario}_traj{opts.trajectory}_"
                          f"{opts.controller_label}_seed{opts.seed}"
                          f"{'' if opts.fmi == 2 else '_fmi3' + ('_clocks' if opts.clocks else '')}")
    log = None if args.no_log else args.out / f"{label}.mcap"
    metrics = loop_metrics() if is_loop(system) else None
    meta = {"vehicle": opts.vehicle, "scenario": opts.scenario, "trajectory": opts.trajectory, "controller": opts.controller,
            "seed": opts.seed, "stop_time": stop, "delay": opts.delay, "fmi": opts.fmi, "clocks": opts.clocks}
    scene = "plant" if "plant" in {i.name for i in system.instances} else None
    print(f"running {label}: {stop:g} s of simulated time")
    result = run_system(system, stop, log, metrics, progress=not args.quiet, metadata=meta, log_every=args.log_every,
                        channels=scene_channels(scene) if scene else (), isolate=None if args.trust_fmus else is_foreign,
                        step_timeout=args.step_timeout, announce=_announce)
    print(f"{result.sim_time:.2f} s simulated in {result.wall:.1f} s ({result.sim_time / max(result.wall, 1e-9):.0f}x real time)")
    if result.metrics and result.ticks:
        print(f"{'metric':>14} {'value':>12}")
        for k, v in result.metrics.items():
            print(f"{k:>14} {v:>12.6g}")
    if log is None or log.is_file():
        print(f"log: {log}" if log else "log: none (--no-log)")
    if result.error:
        return run_failed(result.error, result.signal, log, result.sim_time)
    if not args.no_plots and log is not None:
        files = plot_run(log)
        print(f"plots: {', '.join(str(f) for f in files)}")
    return 0

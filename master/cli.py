"""The `tiltload` command: build the FMUs, run the main job."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import numpy as np

DEFAULT_FMU_DIR = Path("fmus")


class UserError(Exception):
    """A problem the user can fix; reported as one line, exit code 2."""


class OneLineParser(argparse.ArgumentParser):
    """A usage error is one line naming the problem (and where help is), not the usage block."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {message} (see: {self.prog} --help)\n")


def cmd_build(args: argparse.Namespace) -> int:
    from ..formation.build import build as build_formation
    from .build_all import build_all

    for result in [*build_all(args.out, force=args.force, vehicles=("load", "uav")), *build_formation(args.out, args.force)]:
        state = "built" if result.rebuilt else "up to date"
        print(f"{result.path}: {state} ({result.seconds:.1f} s)")
    return 0


def cmd_wrap(args: argparse.Namespace) -> int:
    from .wrap import WrapError, wrap

    try:
        target = wrap(args.controller, args.out, args.cls)
    except WrapError as err:
        raise UserError(str(err)) from None
    print(f"{target}: controller FMU (use it with: tiltload run --controller {target})")
    return 0


def cmd_campaign(args: argparse.Namespace) -> int:
    from .campaign_report import ReportError, report
    from .campaign_spec import SpecError

    try:
        if args.what == "report":
            if args.results is None:
                raise UserError("campaign report: name the results file (e.g. runs/campaigns/NAME/results.parquet)")
            path = report(args.results, args.spec, args.x, args.y)
            print(f"report: {path}")
            return 0
        from .campaign import run

        if args.results is not None:
            raise UserError(f"campaign: unexpected argument {args.results} (to report: tiltload campaign report RESULTS)")
        results, counts = run(Path(args.what), args.out, args.scheduler, args.workers, args.fmus)
    except (SpecError, ReportError) as err:
        raise UserError(str(err)) from None
    print(f"{counts['total']} runs: {counts['skipped']} were done, {counts['ran']} ran, {counts['failed']} failed")
    print(f"results: {results}")
    return 0


def cmd_layout(args: argparse.Namespace) -> int:
    from .foxglove_layout import write

    try:
        path = write(args.out, args.formation)
    except OSError as err:
        raise UserError(f"cannot write {args.out}: {err.strerror or err}") from None
    print(f"{path}: Foxglove layout (in Foxglove: open a run's .mcap, then Layouts -> Import from file)")
    return 0


def cmd_design(args: argparse.Namespace) -> int:
    from ..controller_fmu import artifact
    from ..controller_fmu.design import design
    from ..controller_fmu.error_dynamics import DesignError

    try:
        d = design(args.controller, args.Tc, use_cache=not args.fresh, progress=lambda m: print(m, file=sys.stderr),
                   vehicle=args.vehicle)
    except DesignError as err:
        raise UserError(str(err)) from None
    path = artifact.save(d, args.out / f"{'uav_' if args.vehicle == 'uav' else ''}{d.kind}.json")
    r = d.report
    print(f"{d.kind}: ||K||_2 = {r['gain_norm']:.4g}, closed-loop spectral radius = {r['spectral_radius']:.6f} "
          f"(slowest continuous-time decay {np.log(r['spectral_radius']) / d.Tc:.3f} /s), {r['seconds']:.1f} s")
    if "riccati_residual" in r:
        print(f"  Riccati residual {r['riccati_residual']:.1e}")
    else:
        h2 = f", H2 bound {r['h2_bound']:.4g} (measured {r['h2_norm']:.4g})" if r["h2_bound"] else ""
        print(f"  H-infinity bound {r['gamma_bound']:.4g} (measured {r['hinf_norm']:.4g}){h2}; "
              f"poles in Re > {r['regions']['eps']} and |z| < {r['regions']['varpi']}; solver {r['solver_status']}")
    print(f"saved {path}")
    return 0


def _loop_system(args: argparse.Namespace):
    """The system the run options describe: the thesis's loop (FMUs built when stale), with a controller FMU of the
    user's, parameters set and faults added; or the system a --system file describes. Returns it with the stop time
    and the schedule a package asks for (None for our loop)."""
    from . import system as sysdesc
    from .build_all import build_all
    from .execution import read_fmu
    from .tiltload_system import LOOPS, default_system, set_parameters

    loop = LOOPS[args.vehicle]
    args.trajectory = loop.default_trajectory if args.trajectory is None else args.trajectory
    args.controller = loop.default_controller if args.controller is None else args.controller
    if args.trajectory not in loop.trajectories:
        raise UserError(f"--trajectory {args.trajectory}: the {args.vehicle} vehicle has trajectories "
                        f"{', '.join(map(str, loop.trajectories))}")
    if args.scenario not in loop.scenarios:
        raise UserError(f"--scenario {args.scenario}: the {args.vehicle} vehicle has {', '.join(loop.scenarios)}")
    controller_fmu = None
    if args.controller in ("dlqr", "mixed") and args.controller not in loop.controllers:
        raise UserError(f"--controller {args.controller}: the {args.vehicle} vehicle has {', '.join(loop.controllers)} "
                        "(or your own FMU)")
    if args.controller not in ("dlqr", "mixed"):
        controller_fmu = Path(args.controller)
        if not controller_fmu.is_file():
            raise UserError(f"--controller: {controller_fmu} is neither dlqr, mixed nor an existing FMU file")
    args.controller_fmu = controller_fmu
    stop, schedule = None, None
    try:
        if args.system is not None:
            system, stop, schedule = _read_system(args.system)
        else:
            results = build_all(args.fmus, progress=lambda m: print(m, file=sys.stderr), vehicles=(args.vehicle,))
            rebuilt = [r.path.name for r in results if r.rebuilt]
            if rebuilt:
                print(f"built {', '.join(rebuilt)} into {args.fmus}/")
            system = default_system(args.fmus, args.scenario, args.trajectory, args.controller if controller_fmu is None else None,
                                    args.seed, controller_fmu, args.delay, not args.no_gusts, args.vehicle)
            set_parameters(system, dict(args.set))
            if controller_fmu is not None:
                from .ports import check_controller

                check_controller(read_fmu(controller_fmu, "controller"), args.allow_unknown_inputs, args.vehicle)
        if args.faults is not None:
            from .manipulators import FaultError
            from .manipulators import load as load_faults

            try:
                system.faults = [*system.faults, *load_faults(args.faults)]
            except FaultError as err:
                raise UserError(str(err)) from None
    except sysdesc.DescriptionError as err:
        raise UserError(str(err)) from None
    return system, stop, schedule


def _read_system(path: Path):
    """A system file: an SSP package (.ssp, or a bare .ssd) or a JSON description."""
    from . import ssp
    from . import system as sysdesc

    if path.suffix.lower() in (".ssp", ".ssd"):
        return ssp.load(path)
    return sysdesc.load(path), None, None


def cmd_run(args: argparse.Namespace) -> int:
    from . import system as sysdesc
    from .observers import Metrics
    from .plot import plot_run
    from .run import run_system
    from .tiltload_system import default_stop

    system, package_stop, schedule = _loop_system(args)
    controller_fmu = args.controller_fmu
    schedule = args.schedule or schedule
    if schedule == "jacobi":
        from . import jacobi
        from .execution import read_fmu

        try:
            system = jacobi.explicit(system, {i.name: read_fmu(i.fmu, i.name) for i in system.instances}, jacobi=True)
        except sysdesc.DescriptionError as err:
            raise UserError(str(err)) from None
        print("schedule: jacobi (every output reaches its inputs one step late, as libcosim and Ecos pass them)")
    if args.stop_time is None and package_stop is not None:
        args.stop_time = package_stop
    stop = args.stop_time if args.stop_time is not None else default_stop(args.trajectory)
    who = controller_fmu.stem if controller_fmu else args.controller
    label = args.name or (args.system.stem if args.system is not None else
                          f"{'uav_' if args.vehicle == 'uav' else ''}{args.scenario}_traj{args.trajectory}_{who}_seed{args.seed}")
    log = None if args.no_log else args.out / f"{label}.mcap"
    names = {i.name for i in system.instances}
    metrics = Metrics("plant", "scenario", "controller") if {"plant", "scenario", "controller"} <= names else None
    meta = {"vehicle": args.vehicle, "scenario": args.scenario, "trajectory": args.trajectory, "controller": args.controller,
            "seed": args.seed,
            "stop_time": stop, "delay": args.delay}
    print(f"running {label}: {stop:g} s of simulated time")
    try:
        result = run_system(system, stop, log, metrics, progress=not args.quiet, metadata=meta, log_every=args.log_every,
                            trust_fmus=args.trust_fmus, step_timeout=args.step_timeout, announce=_announce)
    except sysdesc.DescriptionError as err:
        raise UserError(str(err)) from None
    print(f"{result.sim_time:.2f} s simulated in {result.wall:.1f} s ({result.sim_time / max(result.wall, 1e-9):.0f}x real time)")
    if result.metrics and result.ticks:
        print(f"{'metric':>14} {'value':>12}")
        for k, v in result.metrics.items():
            print(f"{k:>14} {v:>12.6g}")
    if log is None or log.is_file():
        print(f"log: {log}" if log else "log: none (--no-log)")
    if result.error:
        where = (f"the log is readable up to t = {result.sim_time:.3f} s" if log.is_file() else "no log was written") if log \
            else "no log (--no-log)"
        print(f"tiltload: error: {result.error}; {where}", file=sys.stderr)
        return 128 + result.signal if result.signal else 1
    if not args.no_plots and log is not None:
        files = plot_run(log)
        print(f"plots: {', '.join(str(f) for f in files)}")
    return 0


def cmd_ssp(args: argparse.Namespace) -> int:
    from . import jacobi, ssp
    from . import system as sysdesc
    from .execution import read_fmu
    from .tiltload_system import default_stop

    system, package_stop, _ = _loop_system(args)  # the one action, export (argparse checked it)
    stop = args.stop_time or package_stop or default_stop(args.trajectory)
    try:
        mds = {i.name: read_fmu(i.fmu, i.name) for i in system.instances}
        names = {i.name for i in system.instances}
        ours = "controller" in names and any(v.name == "loop_delay_ticks" for v in mds["controller"].modelVariables)
        delay = None
        if ours and "loop_delay_ticks" not in system.instance("controller").parameters:
            # the loop delay the package's master will add: Jacobi's one tick per sample-timed connection, or none
            delay = jacobi.loop_delay(jacobi.explicit(system, mds, jacobi=args.schedule == "jacobi"), mds)
            if delay > 2:
                raise UserError(f"the loop would carry {delay} ticks of delay; the designs are made for 0 to 2")
            system.instance("controller").parameters["loop_delay_ticks"] = delay
        path = ssp.export(system, args.out, stop, args.schedule)
    except sysdesc.DescriptionError as err:
        raise UserError(str(err)) from None
    except OSError as err:
        raise UserError(f"cannot write {args.out}: {err.strerror or err}") from None
    print(f"{path}: SSP 1.0 package, {len(system.instances)} FMUs, {stop:g} s, prepared for a {args.schedule} master"
          + (f"; the controller's designs for a {delay}-tick loop delay" if delay is not None else ""))
    print(f"  run it: tiltload run --system {path}   (libcosim: CosimExecution.from_ssp_file; Ecos: init(parameter_set="
          f"'{ssp.PARAMETER_SET}'))")
    return 0


def cmd_formation(args: argparse.Namespace) -> int:
    from ..formation import run as formation

    formation.build_fmus(args.fmus, progress=lambda m: print(m, file=sys.stderr))
    controllers = ("backstepping", "tsid") if args.controller == "both" else (args.controller,)
    runs = []
    for controller in controllers:
        print(f"formation, {controller}{' with disturbances' if args.disturbances else ''}: {args.stop_time:g} s, 7 FMUs")
        r = formation.run(args.fmus, args.out, controller, args.disturbances, args.stop_time, progress=not args.quiet)
        if r.result.error:
            where = f"the log is readable up to t = {r.result.sim_time:.3f} s" if r.log.is_file() else "no log was written"
            print(f"tiltload: error: {r.result.error}; {where}", file=sys.stderr)
            return 128 + r.result.signal if r.result.signal else 1
        print(f"  {r.result.sim_time:.2f} s simulated in {r.result.wall:.1f} s; error norm: max {r.error.max():.4g}, "
              f"over the last 5 s at most {r.settled():.3g}; log: {r.log}")
        runs.append(r)
    if not args.no_plots:
        print(f"plots: {', '.join(str(f) for f in formation.plot(runs, args.out, args.disturbances))}")
    return 0


def _announce(execution) -> None:
    """Before the first step: the inputs nothing feeds (a misspelt port shows up here)."""
    if execution.unconnected:
        print(f"unconnected inputs, held for the whole run: {', '.join(execution.unconnected)}")


def cmd_reproduce(args: argparse.Namespace) -> int:
    from .build_all import build_all
    from .reproduce import main as reproduce_main

    build_all(args.fmus, progress=lambda m: print(m, file=sys.stderr))
    return reproduce_main(args.fmus, args.out, args.docs, args.baselines, args.write_baselines, args.check, args.workers)


def cmd_compare(args: argparse.Namespace) -> int:
    from . import compare as cmp
    from .system import DescriptionError

    notes: list[str] = []
    try:
        run, _ = cmp.load_metrics(args.run, notes)
        base, tol = cmp.load_metrics(args.baseline, notes)
    except DescriptionError as err:
        raise UserError(str(err)) from None
    for note in notes:
        print(f"note: {note}")
    ok, rows = cmp.compare(run, base, args.rtol, args.atol, tol)
    print(cmp.format_rows(rows))
    print("same within tolerance" if ok else "DIFFERENT: at least one metric is out of tolerance")
    return 0 if ok else 1


def cmd_plot(args: argparse.Namespace) -> int:
    from .mcap_log import is_truncated
    from .plot import plot_run

    if not args.log.is_file():
        raise UserError(f"{args.log} does not exist")
    with open(args.log, "rb") as f:
        if f.read(8) != b"\x89MCAP0\r\n":
            raise UserError(f"{args.log} is not an MCAP log (no MCAP magic at its start)")
    if is_truncated(args.log):
        print(f"note: {args.log} is truncated (no footer: a killed run); plotting what it holds")
    try:
        files = plot_run(args.log, args.out)
    except ValueError as err:  # a log of another system: no /plant channel
        raise UserError(str(err)) from None
    for f in files:
        print(f)
    return 0


def _positive_time(text: str) -> float:
    value = float(text)
    if not (value > 0 and value < float("inf")):
        raise argparse.ArgumentTypeError(f"must be a positive finite time in s, got {text}")
    return value


def _assignment(text: str) -> tuple[str, object]:
    from .tiltload_system import parse_value

    key, sep, value = text.partition("=")
    if not sep or "." not in key or not value:
        raise argparse.ArgumentTypeError(f"must be INSTANCE.NAME=VALUE (e.g. plant.m_L=0.2), got {text!r}")
    return key.strip(), parse_value(value.strip())


def _tolerance(text: str) -> float:
    import math

    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a finite number >= 0, got {text}") from None
    if not (math.isfinite(value) and value >= 0):
        raise argparse.ArgumentTypeError(f"must be a finite number >= 0, got {text}")
    return value


def _integer(low: int, high: int | None = None):
    """An argparse type: a whole number in [low, high] (no upper bound if high is None)."""
    what = f"a whole number from {low} to {high}" if high is not None else f"a whole number >= {low}"

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be {what}, got {text}") from None
        if value < low or (high is not None and value > high):
            raise argparse.ArgumentTypeError(f"must be {what}, got {text}")
        return value
    return parse


_seed = _integer(0, 2**31 - 1)
_whole_number = _integer(1)


def _file_stem(text: str) -> str:
    if not text or text in (".", "..") or "/" in text or "\\" in text or "\0" in text or "\n" in text:
        raise argparse.ArgumentTypeError(f"must be a plain file name (no folders), got {text!r}")
    return text


def _loop_options(p: argparse.ArgumentParser) -> None:
    """What describes a run of the loop: shared by run and ssp export."""
    p.add_argument("--vehicle", choices=("load", "uav"), default="load",
                   help="load: the UAV with its suspended load (ch. 5, default); uav: the UAV alone (Appendix A)")
    p.add_argument("--scenario", choices=("fsi", "lkf", "zse"), default="zse", help="estimation scenario (default zse)")
    p.add_argument("--trajectory", type=int, choices=(0, 1, 2, 3), default=None,
                   help="load: 1 circle (default), 2 Table 5.3; uav: 3 Appendix A's circle (default); 0 hover")
    p.add_argument("--controller", default=None,
                   help="dlqr, mixed (the load's default; the UAV alone has dlqr) or PATH.fmu of your own controller")
    p.add_argument("--seed", type=_seed, default=1, help="noise seed, 0 .. 2147483647 (default 1)")
    p.add_argument("--stop-time", type=_positive_time, default=None, help="s (default: the trajectory's duration)")
    p.add_argument("--delay", action="store_true", help="one-tick actuation delay (controller -> plant)")
    p.add_argument("--no-gusts", action="store_true", help="no wind gusts")
    p.add_argument("--faults", type=Path, default=None, metavar="FILE",
                   help="a fault schedule (JSON/YAML, or a libcosim scenario): docs/faults.md")
    p.add_argument("--set", type=_assignment, action="append", default=[], metavar="INSTANCE.NAME=VALUE",
                   help="set an FMU parameter, e.g. --set plant.m_L=0.2 (repeatable)")
    p.add_argument("--system", type=Path, default=None, help="an SSP package (.ssp/.ssd) or a JSON system description instead of the loop")
    p.add_argument("--fmus", type=Path, default=DEFAULT_FMU_DIR, help="FMU folder (default: fmus)")
    p.add_argument("--allow-unknown-inputs", action="store_true",
                   help="accept a controller FMU whose inputs include names the port contract does not have")


def main(argv: list[str] | None = None) -> int:
    parser = OneLineParser(prog="tiltload", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    b = sub.add_parser("build", help="build the FMUs into fmus/ (only what is missing or stale)")
    b.add_argument("--out", type=Path, default=DEFAULT_FMU_DIR, help="output folder (default: fmus)")
    b.add_argument("--force", action="store_true", help="rebuild even if up to date")
    b.set_defaults(func=cmd_build)
    d = sub.add_parser("design", help="design a controller of the thesis (ch. 3) and save it as an artifact")
    d.add_argument("--controller", default="dlqr", help="dlqr (default), hinf or mixed")
    d.add_argument("--vehicle", choices=("load", "uav"), default="load", help="load (default) or uav: the UAV alone (dlqr only)")
    d.add_argument("--Tc", type=_positive_time, default=0.012, help="controller period in s (default 0.012)")
    d.add_argument("--out", type=Path, default=Path("designs"), help="output folder (default: designs)")
    d.add_argument("--fresh", action="store_true", help="synthesize again even if an identical design is cached")
    d.set_defaults(func=cmd_design)
    w = sub.add_parser("wrap", help="package your Python controller class as a controller FMU (docs/ports.md)")
    w.add_argument("controller", type=Path, help="the .py file with the controller class")
    w.add_argument("--class", dest="cls", default=None, help="the class to wrap, if the file has several")
    w.add_argument("--out", type=Path, default=None, help="the FMU to write (default: next to the file, <name>.fmu)")
    w.set_defaults(func=cmd_wrap)
    r = sub.add_parser("run", help="main job: run the closed loop through the FMUs, log to MCAP, print ISE/IADU, plot")
    _loop_options(r)
    r.add_argument("--schedule", choices=("ordered", "jacobi"), default=None,
                   help="ordered: tiltload's master (default); jacobi: as libcosim and Ecos step (a package's own choice "
                        "is the default for it)")
    r.add_argument("--out", type=Path, default=Path("runs"), help="where the log and plots go (default: runs)")
    r.add_argument("--name", type=_file_stem, default=None, help="file name stem of the log")
    r.add_argument("--trust-fmus", action="store_true",
                   help="run every FMU inside this process (default: FMUs tiltload did not build run each in its own "
                        "process, so a crash, exit() or hang in one ends the run with one line)")
    r.add_argument("--step-timeout", type=_positive_time, default=None, metavar="S",
                   help="watchdog for an FMU in its own process: the longest a call may take (default 10 s)")
    r.add_argument("--no-plots", action="store_true", help="skip the PNG figures")
    r.add_argument("--no-log", action="store_true", help="no MCAP log: metrics only (campaigns); implies --no-plots")
    r.add_argument("--log-every", type=_whole_number, default=1, metavar="N",
                   help="log every N-th step of each FMU (default 1: every step)")
    r.add_argument("--quiet", action="store_true", help="no progress bar")
    r.set_defaults(func=cmd_run)
    x = sub.add_parser("ssp", help="export the loop as an SSP 1.0 package that libcosim, Ecos and tiltload run (docs/ports.md)")
    x.add_argument("action", choices=("export",), help="export: write the package")
    x.add_argument("out", type=Path, help="the package to write, e.g. loop.ssp")
    _loop_options(x)
    x.add_argument("--schedule", choices=("jacobi", "ordered"), default="jacobi",
                   help="the master the package is for: jacobi (libcosim, Ecos; default) selects the designs made for the "
                        "2-tick loop delay it adds; ordered (tiltload) selects 0")
    x.set_defaults(func=cmd_ssp)
    fo = sub.add_parser("formation", help="the formation of three UAVs (Appendix B): 7 FMUs, log, error norms, paths")
    fo.add_argument("--controller", choices=("both", "backstepping", "tsid"), default="both",
                    help="the formation controller: backstepping (B.15), tsid (B.16) or both (default, one figure)")
    fo.add_argument("--disturbances", action="store_true",
                    help="constant acceleration disturbances and external forces from t = 10 s (docs/formation.md)")
    fo.add_argument("--stop-time", type=_positive_time, default=60.0, help="s (default 60)")
    fo.add_argument("--fmus", type=Path, default=DEFAULT_FMU_DIR, help="FMU folder (default: fmus)")
    fo.add_argument("--out", type=Path, default=Path("runs/formation"), help="logs and figures (default runs/formation)")
    fo.add_argument("--no-plots", action="store_true", help="skip the PNG figures")
    fo.add_argument("--quiet", action="store_true", help="no progress bar")
    fo.set_defaults(func=cmd_formation)
    rp = sub.add_parser("reproduce", help="the twelve cases of ch. 5 in parallel: tables vs the thesis, figures, baselines")
    rp.add_argument("--fmus", type=Path, default=DEFAULT_FMU_DIR)
    rp.add_argument("--out", type=Path, default=Path("runs/reproduce"), help="logs, figures, results.md (default runs/reproduce)")
    rp.add_argument("--docs", type=Path, default=None, help="also write this results document (e.g. docs/results.md)")
    rp.add_argument("--baselines", type=Path, default=Path("baselines"), help="baseline folder (default baselines)")
    rp.add_argument("--write-baselines", action="store_true", help="store the metrics as the new baselines")
    rp.add_argument("--check", action="store_true", help="compare every case with its baseline; exit 1 on a difference")
    rp.add_argument("--workers", type=int, default=None, help="processes (default: one per core)")
    rp.set_defaults(func=cmd_reproduce)
    cp = sub.add_parser("compare", help="compare a run's metrics with a baseline (a log or a metrics file); exit 0 same, 1 different")
    cp.add_argument("run", type=Path)
    cp.add_argument("baseline", type=Path)
    cp.add_argument("--rtol", type=_tolerance, default=1e-6, help="relative tolerance (default 1e-6)")
    cp.add_argument("--atol", type=_tolerance, default=1e-12, help="absolute tolerance (default 1e-12)")
    cp.set_defaults(func=cmd_compare)
    ca = sub.add_parser("campaign", help="run a campaign spec on Dask (TOML/YAML), or 'report RESULTS' to summarize one")
    ca.add_argument("what", help="the campaign spec, or 'report'")
    ca.add_argument("results", nargs="?", type=Path, default=None, help="with report: the results.parquet")
    ca.add_argument("--out", type=Path, default=None, help="results folder (default runs/campaigns/<name>)")
    ca.add_argument("--scheduler", default=None, help="an existing Dask scheduler, tcp://HOST:PORT (default: a local cluster)")
    ca.add_argument("--workers", type=_whole_number, default=None, help="local cluster size (default: one per core)")
    ca.add_argument("--fmus", type=Path, default=DEFAULT_FMU_DIR, help="FMU folder (default: fmus)")
    ca.add_argument("--spec", type=Path, default=None, help="with report: the spec, for the rerun commands")
    ca.add_argument("--x", default=None, help="with report: the varied parameter on the maps' x axis")
    ca.add_argument("--y", default=None, help="with report: the varied parameter on the maps' y axis")
    ca.set_defaults(func=cmd_campaign)
    lo = sub.add_parser("layout", help="write the Foxglove layout for tiltload logs (3D replay, tracking, bounds, actuators)")
    lo.add_argument("out", type=Path, nargs="?", default=Path("runs/foxglove_layout.json"))
    lo.add_argument("--formation", action="store_true", help="the layout for `tiltload formation` logs (three UAVs)")
    lo.set_defaults(func=cmd_layout)
    pl = sub.add_parser("plot", help="draw the thesis's kinds of figures from a run's MCAP log")
    pl.add_argument("log", type=Path)
    pl.add_argument("--out", type=Path, default=None, help="folder for the PNGs (default: next to the log)")
    pl.set_defaults(func=cmd_plot)
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except UserError as err:
        print(f"tiltload: error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("tiltload: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # the reader of our output went away (e.g. `| head`): stop, as a pipe writer does
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        print("tiltload: stopped: standard output was closed (broken pipe)", file=sys.stderr)
        return 141
    except Exception as err:  # one line for the user; TILTLOAD_DEBUG=1 shows the traceback
        from ..native_fmu.build import BuildError

        if isinstance(err, BuildError):  # the compiler failed or is missing: the environment, not a bug
            print(f"tiltload: error: building the FMUs failed: {err}", file=sys.stderr)
            return 1
        if os.environ.get("TILTLOAD_DEBUG"):
            raise
        print(f"tiltload: error: unexpected failure, a bug ({err!s:.300}); TILTLOAD_DEBUG=1 shows where", file=sys.stderr)
        return 1


def entry() -> None:
    """The `tiltload` command: main(), then an exit that a loaded pythonfmu controller cannot crash."""
    from .pythonfmu_guard import exit_now, pinned
    from .run import terminate_like_interrupt

    terminate_like_interrupt()
    code = main()
    if pinned():
        exit_now(code)
    sys.exit(code)


if __name__ == "__main__":
    entry()

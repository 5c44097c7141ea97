"""`tiltload run`: the main job. Build what is stale, run the loop (or a system file), log, score, plot."""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from .. import arguments
from ..errors import UserError

if TYPE_CHECKING:
    from ...engine.run import RunResult
    from ..options import LoopOptions


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
    r.add_argument("--step-timeout", type=arguments.time_span(arguments.DAY), default=None, metavar="S",
                   help=f"watchdog for an FMU in its own process: the longest a call may take (default 10 s; at most "
                        f"{arguments.DAY:g} s)")
    r.add_argument("--token-file", type=Path, default=None, metavar="FILE",
                   help="the shared secret of the tiltload serve a --remote instance runs on (docs/remote.md)")
    r.add_argument("--no-plots", action="store_true", help="skip the PNG figures")
    r.add_argument("--no-log", action="store_true", help="no MCAP log: metrics only (campaigns); implies --no-plots")
    r.add_argument("--log-every", type=arguments.whole_number, default=1, metavar="N",
                   help="log every N-th step of each FMU (default 1: every step)")
    r.add_argument("--quiet", action="store_true", help="no progress bar")
    r.add_argument("--requirements", type=Path, default=None, metavar="REQS",
                   help="monitor these requirements (STL, YAML: docs/requirements.md) while the run goes: verdicts in the "
                        "table and the log")
    r.add_argument("--stop-on-violation", action="store_true",
                   help="with --requirements: end the run once a requirement's FAIL can no longer change")
    r.add_argument("--snapshot-at", nargs=2, metavar=("T", "FILE"), default=None,
                   help="at t = T s write every FMU's state and the master's to FILE (the run goes on)")
    r.add_argument("--from-snapshot", type=Path, default=None, metavar="FILE",
                   help="continue the run a snapshot was taken of (with --faults, --set of tunable parameters, --stop-time)")
    r.add_argument("--realtime", type=arguments.realtime_factor, nargs="?", const=1.0, default=None, metavar="FACTOR",
                   help=f"pace the ticks against the monotonic clock, FACTOR x real time (default 1; from "
                        f"{1 / arguments.MAX_REALTIME_FACTOR:g} to {arguments.MAX_REALTIME_FACTOR:g}); overruns are reported")
    r.add_argument("--max-overruns", type=arguments.integer(0), default=None, metavar="N",
                   help="with --realtime: stop the run once more than N ticks missed their deadline")
    r.set_defaults(func=run)


def _announce(execution) -> None:
    """Before the first step: the inputs nothing feeds (a misspelt port shows up here), the instances run elsewhere."""
    if execution.unconnected:
        print(f"unconnected inputs, held for the whole run: {', '.join(execution.unconnected)}")
    remote = [i for i in execution.system.instances if i.remote]
    if remote:
        print(f"remote: {', '.join(f'{i.name} on tiltload serve at {i.remote}' for i in remote)}")


def _with_token(system, token_file: Path | None) -> None:
    """The run's secret for every instance that runs on a tiltload serve: read now, so a bad file is one line."""
    from ...engine.isolation.handshake import read_token
    from ..errors import UserError

    remote = [i.name for i in system.instances if i.remote]
    if remote and token_file is None:
        raise UserError(f"{', '.join(remote)} run on tiltload serve: give its shared secret with --token-file")
    if remote:
        read_token(token_file)
    for inst in system.instances:
        if inst.remote:
            inst.token_file = token_file


# the options that say which loop runs: a run continued from a snapshot takes them from the snapshot
# (their argparse defaults: None or False, so a given option is one that is neither)
_LOOP_DEFINING = ("vehicle", "scenario", "trajectory", "controller", "seed", "delay", "no_gusts", "system", "schedule",
                  "allow_unknown_inputs", "wind", "fmi", "clocks")
# files the snapshot names but never locates: the command line gives them again, and their digests are checked
_NAMED_FILES = {"controller": "controller_fmu", "system": "system"}


def _branch(args: argparse.Namespace):
    """(snapshot, the loop options it was taken with, this run's faults and stop time instead of its own).
    A snapshot is data: its FMUs are those of the command line's folder (--fmus, default fmus/), and a controller FMU or
    system file of the user's is the one the command line names again; snapshot.check compares each with the digests
    recorded before anything is loaded."""
    from ...engine import snapshot
    from ..arguments import DEFAULT_FMU_DIR
    from ..options import snapshot_options

    def refuse(given: list[str]) -> None:
        if given:
            raise UserError(f"--from-snapshot: {', '.join(given)} cannot change in a continued run (the snapshot says "
                            "which loop it is; --faults, --set of tunable parameters and --stop-time can)")

    refuse([f"--{k.replace('_', '-')}" for k in _LOOP_DEFINING if getattr(args, k, None) not in (None, False)
            and k not in _NAMED_FILES])  # before the file is read; --controller and --system once it says which it needs
    if args.snapshot_at is not None:
        raise UserError("--from-snapshot and --snapshot-at together: continue first, then take a new snapshot in a later run")
    snap = snapshot.read(args.from_snapshot)
    opts = snapshot_options(snap.application, args.from_snapshot)
    stop, schedule = snap.application.get("stop"), snap.application.get("schedule")
    if not (stop is None or (isinstance(stop, (int, float)) and not isinstance(stop, bool) and 0 < stop < float("inf"))):
        raise UserError(f"{args.from_snapshot}: its stop time is not a positive number of seconds ({stop!r})")
    if schedule not in (None, "ordered", "jacobi"):
        raise UserError(f"{args.from_snapshot}: its schedule {str(schedule)[:40]!r} is neither ordered nor jacobi")
    needed = {flag: getattr(opts, field) for flag, field in _NAMED_FILES.items() if getattr(opts, field) is not None}
    refuse([f"--{k}" for k in _NAMED_FILES if getattr(args, k, None) is not None and k not in needed])
    import dataclasses

    for flag, recorded in needed.items():
        path = getattr(args, flag)
        if path is None:
            raise UserError(f"--from-snapshot {args.from_snapshot}: it was taken with the {flag} file {Path(recorded).name}: "
                            f"name it again with --{flag} PATH (a snapshot never says where files are; its digest is checked)")
        if not Path(path).is_file():
            raise UserError(f"--{flag} {path}: no such file")
        opts = dataclasses.replace(opts, **({"controller": str(path), "controller_fmu": Path(path)} if flag == "controller"
                                            else {"system": Path(path)}))
    _same_places(dict(opts.remotes), dict(args.remote), args.from_snapshot)
    opts = dataclasses.replace(opts, faults=args.faults if args.faults is not None else opts.faults,
                               fmus=args.fmus or DEFAULT_FMU_DIR, stop_time=args.stop_time or stop or opts.stop_time,
                               remotes=tuple(args.remote))  # where an instance runs is this run's, not the snapshot's
    branch: dict[str, dict] = {}
    for key, value in args.set:
        instance, _, name = key.partition(".")
        branch.setdefault(instance, {})[name] = value
    snap.settings = branch
    return snap, opts


def _same_places(then: dict[str, str], now: dict[str, str], path: Path) -> None:
    """An FMU's serialized state is its machine's (a library built elsewhere may lay its memory out otherwise): a run
    continues with each instance where it ran when the snapshot was taken, on a tiltload serve or here (the server's
    address may change)."""
    for name in sorted(set(then) ^ set(now)):
        if name in then:
            raise UserError(f"--from-snapshot {path}: {name} ran on tiltload serve at {then[name]} when it was taken, and "
                            f"its state is that machine's: continue with --remote {name}=HOST:PORT")
        raise UserError(f"--from-snapshot {path}: {name} ran in this master's machine when it was taken, and its state "
                        f"is this machine's: continue without --remote {name}")


def _snapshot_at(args: argparse.Namespace):
    if args.snapshot_at is None:
        return None
    at, path = args.snapshot_at
    try:
        return arguments.positive_time(at), Path(path)
    except argparse.ArgumentTypeError as err:
        raise UserError(f"--snapshot-at {at}: {err}") from None


def _metadata(opts, stop: float, schedule: str | None) -> dict:
    """The log's "run" record: which case this run was, as it ran (a system file's own settings are in the file)."""
    from ..regression.case import file_digest, record

    if opts.system is not None:
        meta = {"system": str(opts.system), "system_sha256": file_digest(opts.system), "stop_time": stop}
        if opts.faults is not None:
            meta["faults"], meta["faults_sha256"] = str(opts.faults), file_digest(opts.faults)
        return meta
    return record(vehicle=opts.vehicle, scenario=opts.scenario, trajectory=opts.trajectory, controller=opts.controller,
                  seed=opts.seed, delay=opts.delay, gusts=opts.gusts, fmi=opts.fmi, clocks=opts.clocks, settings=opts.settings,
                  faults=opts.faults, wind=opts.wind, schedule=schedule or "ordered", stop_time=stop)


@dataclass
class Outcome:
    """What a `tiltload run` did: its exit code and what ran (the public API, tiltload.run, reads it)."""

    code: int
    opts: LoopOptions
    metadata: dict  # the log's "run" record
    result: RunResult
    log: Path | None
    plots: list[Path]
    failure: str | None  # the one line of a run that ended early
    requirements: tuple = ()  # the requirements' results (engine.requirement_check.Result) when --requirements was given


def run(args: argparse.Namespace) -> int:
    return execute(args).code


def execute(args: argparse.Namespace) -> Outcome:
    """The run in its steps: the options (or a snapshot's), the system built, its schedule, the log's name, the run,
    what it printed and its outcome."""
    _say_preparing(args)
    from ....controller_fmu.design.cache import cache_root
    from ...engine.run import run_system
    from ..fmus import is_foreign
    from ..loop import is_loop, loop_metrics
    from ..loop_system import loop_system
    from ..regression.thesis_values import beside_run
    from ..scene import scene_channels

    pacer = _pacer(args)
    snap, opts = _options(args)
    checkpoint = _snapshot_at(args)
    loop = loop_system(opts, cache_root() / "ssp", build=snap is None)  # a continued run builds nothing
    system, stop = loop.system, loop.stop
    if snap is not None and stop <= snap.time + snap.tick / 2:  # as a campaign refuses it: nothing left to run
        raise UserError(f"--stop-time {stop:g}: a continued run must stop after the snapshot's time ({snap.time:g} s)")
    _with_token(system, args.token_file)
    system, schedule = _scheduled(args, loop, system, snap)
    label, log = _log_path(args, opts, loop, snap)
    metrics = loop_metrics() if is_loop(system) else None
    meta = _metadata(opts, stop, schedule)
    checkpoints = _checkpoints(checkpoint, opts, schedule, stop)
    if snap is not None:
        meta["from_snapshot"] = f"{args.from_snapshot} (t = {snap.time:.3f} s)"
        print(f"continuing from {args.from_snapshot}: t = {snap.time:.3f} s")
    monitor = _monitor(args, system)
    scene = "plant" if "plant" in {i.name for i in system.instances} else None
    print(f"running {label}: {stop:g} s of simulated time" + (f", paced at {args.realtime:g}x real time" if pacer else ""))
    result = run_system(system, stop, log, metrics, progress=not args.quiet, metadata=meta, log_every=args.log_every,
                        channels=scene_channels(scene) if scene else (), isolate=None if args.trust_fmus else is_foreign,
                        step_timeout=args.step_timeout, announce=_announce, realtime=pacer, resume=snap,
                        checkpoints=checkpoints, observers_extra=[monitor] if monitor else ())
    _print_results(result, snap, monitor, pacer, log, beside_run(opts, stop))
    return _outcome(args, opts, meta, result, log, monitor)


def _say_preparing(args: argparse.Namespace) -> None:
    if not args.quiet:  # before the imports (numpy, CasADi, FMPy: seconds): the user sees at once that it started
        print("tiltload run: preparing " + (f"the run continued from {args.from_snapshot}" if args.from_snapshot else
                                            f"the system {args.system}" if args.system else
                                            f"the loop (FMUs missing or stale in {args.fmus or 'fmus'}/ are built first)")
              + " ...", flush=True)


def _pacer(args: argparse.Namespace):
    """The real-time pacer of --realtime, or None."""
    if args.realtime is not None:
        from ...engine.realtime import Pacer

        return Pacer(args.realtime, args.max_overruns)
    if args.max_overruns is not None:
        raise UserError("--max-overruns needs --realtime")
    return None


def _options(args: argparse.Namespace):
    """(the snapshot continued or None, the loop's options: the snapshot's, or the command line's)."""
    from ..options import resolve_loop

    if args.from_snapshot is not None:
        return _branch(args)
    return None, resolve_loop(args)


def _scheduled(args: argparse.Namespace, loop, system, snap):
    """(the system as its schedule runs it, the schedule): the snapshot's, the command line's or the loop's own."""
    from ...engine import jacobi
    from ...engine.model_description import read_fmu

    schedule = (snap.application.get("schedule") if snap else None) or args.schedule or loop.schedule
    if schedule == "jacobi":
        system = jacobi.explicit(system, {i.name: read_fmu(i.fmu, i.name) for i in system.instances}, jacobi=True)
        print("schedule: jacobi (every output reaches its inputs one step late, as libcosim and Ecos pass them)")
    return system, schedule


def _log_path(args: argparse.Namespace, opts, loop, snap) -> tuple[str, Path | None]:
    """(the run's label, its log or None with --no-log); a log replaced is said."""
    from ..log_name import default_log_name

    label = args.name or default_log_name(args, opts, loop.natural_stop, loop.schedule, snap.time if snap else None)
    log = None if args.no_log else args.out / f"{label}.mcap"
    if log is not None and log.exists():  # never replaced without a word (a different run gets a different default name)
        print(f"note: {log} exists (an earlier run of the same options, or --name): it and its figures are replaced")
    return label, log


def _checkpoints(checkpoint, opts, schedule: str | None, stop: float) -> list:
    """--snapshot-at as the engine's (time, action) checkpoint."""
    if checkpoint is None:
        return []
    from ...engine import snapshot

    at, path = checkpoint
    if not 0 < at <= stop:  # at the stop time: the run's end state, to continue later with a later --stop-time
        raise UserError(f"--snapshot-at {at:g}: must fall inside the run or at its end (0 < T <= {stop:g} s)")
    application = {"options": opts.to_dict(), "schedule": schedule, "stop": stop}

    def save(execution) -> None:
        print(f"snapshot at t = {execution.time:.3f} s: {snapshot.write(snapshot.take(execution, application), path)}")
    return [(at, save)]


def _print_results(result, snap, monitor, pacer, log: Path | None, thesis: tuple = ("", None)) -> None:
    """The speed, the metrics (beside the thesis's values for a thesis case: thesis_values.beside_run), the requirements'
    verdicts, the pacer's overruns and where the log went."""
    simulated = result.sim_time - (snap.time if snap and result.ticks else 0.0)
    print(f"{simulated:.2f} s simulated in {result.wall:.1f} s ({simulated / max(result.wall, 1e-9):.0f}x real time)"
          + (f", from t = {snap.time:.3f} s" if snap else ""))
    if result.metrics and result.ticks:
        what, values = thesis
        print(f"{'metric':>14} {'value':>12}" + (f"  thesis ({what})" if values else ""))
        for k, v in result.metrics.items():
            print(f"{k:>14} {v:>12.6g}" + (f"  {values[k]:>10.6g}" if values and k in values else ""))
        if what and values is None:
            print(f"note: {what}")
    if monitor is not None and monitor.results:
        from .check import table

        print("requirements:")
        print("\n".join(table(monitor.results)))
    if pacer is not None:
        print(pacer.summary())
    if log is None or log.is_file():
        print(f"log: {log}" if log else "log: none (--no-log)")


def _outcome(args: argparse.Namespace, opts, meta: dict, result, log: Path | None, monitor) -> Outcome:
    """A failed run's one line (exit 1, or 128 + the signal), else the plots and the requirements' verdicts (exit 1 on a
    FAIL)."""
    from ..errors import failure_line
    from ..plot import plot_run

    if result.error:
        failure = failure_line(result.error, log, result.sim_time)
        print(f"tiltload: error: {failure}", file=sys.stderr)
        return Outcome(128 + result.signal if result.signal else 1, opts, meta, result, log, [], failure)
    files = []
    if not args.no_plots and log is not None:
        files = plot_run(log)
        print(f"plots: {', '.join(str(f) for f in files)}")
    verdicts = tuple(monitor.results) if monitor is not None else ()
    return Outcome(1 if any(r.verdict == "FAIL" for r in verdicts) else 0, opts, meta, result, log, files, None, verdicts)


def _monitor(args: argparse.Namespace, system):
    """The requirements' observer, its signals checked against the FMUs' outputs before anything runs."""
    if args.requirements is None:
        if args.stop_on_violation:
            raise UserError("--stop-on-violation needs --requirements")
        return None
    from ...engine.model_description import read_fmu
    from ...engine.requirement_observer import RequirementObserver
    from ...engine.requirements import check_signals, load

    reqs = load(args.requirements)
    available = {}
    for inst in system.instances:
        for v in read_fmu(inst.fmu, inst.name).modelVariables:
            if v.causality == "output":
                available[f"{inst.name}.{v.name}"] = "number" if v.type in ("Real", "Integer", "Boolean") else f"a {v.type}"
    check_signals(reqs, available, "the run's outputs")
    return RequirementObserver(reqs, stop_on_violation=args.stop_on_violation, log_every=args.log_every)

"""The core of `tiltload run` and tiltload.run: a Case run with its RunOptions, from the options to the outcome. It
prints nothing: every line it has to say goes to the report callback (the command prints them, the API keeps them)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from ..user_error import UserError
from .case import Case
from .run_options import RunOptions

if TYPE_CHECKING:
    from ...engine.run import RunResult
    from ..case.options import LoopOptions

Say = Callable[[str], None]


@dataclass
class Outcome:
    """What a run did: its exit code (0, 1 on a FAIL or a run ended early, 128 + a signal) and what ran."""

    code: int
    opts: LoopOptions  # the case resolved (a continued run's: the snapshot's)
    metadata: dict  # the log's "run" record
    result: RunResult
    log: Path | None
    plots: list[Path]
    failure: str | None  # the one line of a run that ended early
    requirements: tuple = ()  # the requirements' results (engine.requirement.check.Result) when requirements were given


def preparing(case: Case, options: RunOptions) -> str:
    """The first line, said before the imports (numpy, CasADi, FMPy: seconds), so the user sees at once that it started."""
    return ("tiltload run: preparing " + (f"the run continued from {options.from_snapshot}" if options.from_snapshot else
                                          f"the system {case.system}" if case.system else
                                          f"the loop (FMUs missing or stale in {case.fmus or 'fmus'}/ are built first)")
            + " ...")


def execute(case: Case, options: RunOptions, say: Say, pool=None) -> Outcome:
    """The run in its steps: the options (or a snapshot's), the system built, its schedule, the log's name, the run,
    its results said and its outcome. pool (engine.lifecycle.ExecutionPool): whoever runs many cases keeps the
    executions between them (restarted, not instantiated again); None: the run's own, closed after it."""
    from ....controller_fmu.design.cache import cache_root
    from ...engine.lifecycle import RunPlan, run_plan
    from ..case.system import build_system
    from ..loop.fmus import is_foreign
    from ..loop.scene import scene_channels
    from ..loop.thesis import is_loop, loop_metrics
    from ..regression.thesis_values import beside_run

    pacer = _pacer(options)
    snap, opts = _options(case, options)
    checkpoint = None if options.snapshot_at is None else (options.snapshot_time, options.snapshot_at[1])
    loop = build_system(opts, cache_root() / "ssp", build=snap is None, say=say)  # a continued run builds nothing
    system, stop = loop.system, loop.stop
    if system.start_time and (options.requirements is not None or options.snapshot_at is not None or snap is not None):
        raise UserError(f"the system starts at {system.start_time:g} s: --requirements, --snapshot-at and "
                        "--from-snapshot are for runs from t = 0 only")
    _check_expected(system, options.expect_fmu)
    if snap is not None and stop <= snap.time + snap.tick / 2:  # as a campaign refuses it: nothing left to run
        raise UserError(f"--stop-time {stop:g}: a continued run must stop after the snapshot's time ({snap.time:g} s)")
    _with_token(system, options.token_file)
    system, schedule = _scheduled(case, loop, system, snap, say)
    label, log = _log_path(case, options, opts, loop, snap, say)
    if options.report is not None:  # before the run: a report that cannot be written, or would overwrite an input
        from ..output_folder import writable_file

        writable_file(options.report, "--report", _run_inputs(case, options, log))
    metrics = loop_metrics() if is_loop(system) else None
    meta = _metadata(opts, stop, schedule)
    checkpoints = _checkpoints(checkpoint, opts, schedule, stop, say)
    if snap is not None:
        meta["from_snapshot"] = f"{options.from_snapshot} (t = {snap.time:.3f} s)"
        say(f"continuing from {options.from_snapshot}: t = {snap.time:.3f} s")
    monitor = _monitor(options, system, stop - (snap.time if snap else 0.0))
    scene = "plant" if "plant" in {i.name for i in system.instances} else None
    t0 = system.start_time
    say(f"running {label}: {stop - t0:g} s of simulated time" + (f" from t = {t0:g} s" if t0 else "")
        + (f", paced at {options.realtime:g}x real time" if pacer else ""))
    plan = RunPlan(system, stop, log, meta, tuple(scene_channels(scene)) if scene else (), options.log_every, metrics,
                   (monitor,) if monitor else (), not options.quiet, None if options.trust_fmus else is_foreign,
                   options.step_timeout, pacer, snap, tuple(checkpoints), lambda execution: _announce(execution, say, stop),
                   profile=options.profile)
    result = run_plan(plan, pool)
    _say_results(result, snap, monitor, pacer, log, say, beside_run(opts, stop), t0)
    if result.profile is not None:
        for line in result.profile.lines():
            say(line)
    outcome = _outcome(options, opts, meta, result, log, monitor, say)
    if options.report is not None:
        _report(case, options, system, outcome, monitor, say)
    return outcome


def _announce(execution, say: Say, stop: float) -> None:
    """Before the first step: where the run ends if not at the stop time asked (engine/edges.py), the inputs nothing
    feeds (a misspelt port shows up here), the instances run elsewhere."""
    note = execution.stop_plan(stop).note
    if note:
        say(note)
    if execution.unconnected:
        say(f"unconnected inputs, held for the whole run: {', '.join(execution.unconnected)}")
    remote = [i for i in execution.system.instances if i.remote]
    if remote:
        say(f"remote: {', '.join(f'{i.name} on tiltload serve at {i.remote}' for i in remote)}")


def _check_expected(system, expected: tuple[tuple[str, str], ...]) -> None:
    """--expect-fmu: each named instance's FMU is the build of that SHA-256, checked before anything runs (a file
    rebuilt at the same path is another FMU: its run would say nothing of the one expected)."""
    from ...engine.log.provenance import fmu_digest

    fmus = {i.name: i.fmu for i in system.instances}
    for name, digest in expected:
        if name not in fmus:
            raise UserError(f"--expect-fmu {name}: no instance {name} in this run (have: {', '.join(fmus)})")
        found = fmu_digest(fmus[name])
        if found != digest:
            raise UserError(f"--expect-fmu {name}: {fmus[name]} is not the FMU expected (sha256 {found[:12]}..., expected "
                            f"{digest[:12]}...): it was rebuilt or replaced since; run on it without --expect-fmu to judge "
                            "the new build")


def _with_token(system, token_file: Path | None) -> None:
    """The run's secret for every instance that runs on a tiltload serve: read now, so a bad file is one line."""
    from ...engine.isolation.handshake import read_token

    remote = [i.name for i in system.instances if i.remote]
    if remote and token_file is None:
        raise UserError(f"{', '.join(remote)} run on tiltload serve: give its shared secret with --token-file")
    if remote:
        read_token(token_file)
    for inst in system.instances:
        if inst.remote:
            inst.token_file = token_file


def _metadata(opts, stop: float, schedule: str | None) -> dict:
    """The log's "run" record: which case this run was, as it ran (a system file's own settings are in the file)."""
    from ..case.record import file_digest, record

    if opts.system is not None:
        meta = {"system": str(opts.system), "system_sha256": file_digest(opts.system), "stop_time": stop,
                **({"start_time": opts.start_time} if opts.start_time is not None else {})}
        if opts.faults is not None:
            meta["faults"], meta["faults_sha256"] = str(opts.faults), file_digest(opts.faults)
        return meta
    return record(vehicle=opts.vehicle, scenario=opts.scenario, trajectory=opts.trajectory, controller=opts.controller,
                  seed=opts.seed, delay=opts.delay, gusts=opts.gusts, fmi=opts.fmi, clocks=opts.clocks, settings=opts.settings,
                  faults=opts.faults, wind=opts.wind, schedule=schedule or "ordered", stop_time=stop)


def _pacer(options: RunOptions):
    """The real-time pacer of realtime, or None."""
    if options.realtime is not None:
        from ...engine.realtime import Pacer

        return Pacer(options.realtime, options.max_overruns)
    if options.max_overruns is not None:
        raise UserError("--max-overruns needs --realtime")
    return None


def _options(case: Case, options: RunOptions):
    """(the snapshot continued or None, the loop's options: the snapshot's, or the case's)."""
    if options.from_snapshot is not None:
        from .continued import continued

        return continued(case, options)
    return None, case.loop_options()


def _scheduled(case: Case, loop, system, snap, say: Say):
    """(the system as its schedule runs it, the schedule): the snapshot's, the case's or the loop's own."""
    from ...engine import jacobi
    from ...engine.fmi.model_description import read_fmu

    schedule = (snap.application.get("schedule") if snap else None) or case.schedule or loop.schedule
    if schedule == "jacobi":
        system = jacobi.explicit(system, {i.name: read_fmu(i.fmu, i.name) for i in system.instances}, jacobi=True)
        say("schedule: jacobi (every output reaches its inputs one step late, as libcosim and Ecos pass them)")
    return system, schedule


def _log_path(case: Case, options: RunOptions, opts, loop, snap, say: Say) -> tuple[str, Path | None]:
    """(the run's label, its log or None with no_log); a log replaced is said."""
    from ..case.log_name import default_log_name

    label = options.name or default_log_name(options, opts, loop.natural_stop, loop.schedule, snap.time if snap else None,
                                             case.schedule)
    log = None if options.no_log else options.out / f"{label}.mcap"
    if log is not None and log.exists():  # never replaced without a word (a different run gets a different default name)
        say(f"note: {log} exists (an earlier run of the same options, or --name): it and its figures are replaced")
    return label, log


def _checkpoints(checkpoint, opts, schedule: str | None, stop: float, say: Say) -> list:
    """snapshot_at as the engine's (time, action) checkpoint."""
    if checkpoint is None:
        return []
    from ...engine import snapshot

    at, path = checkpoint
    if not 0 < at <= stop:  # at the stop time: the run's end state, to continue later with a later --stop-time
        raise UserError(f"--snapshot-at {at:g}: must fall inside the run or at its end (0 < T <= {stop:g} s)")
    application = {"options": opts.to_dict(), "schedule": schedule, "stop": stop}

    def save(execution) -> None:
        say(f"snapshot at t = {execution.time:.3f} s: {snapshot.write(snapshot.take(execution, application), path)}")
    return [(at, save)]


def _say_results(result, snap, monitor, pacer, log: Path | None, say: Say, thesis: tuple = ("", None),
                 start: float = 0.0) -> None:
    """The speed, the metrics (beside the thesis's values for a thesis case: thesis_values.beside_run), the requirements'
    verdicts, the pacer's overruns and where the log went."""
    from ...engine.observers import seconds, speed  # the progress bar's words and clock: the two agree

    simulated = max(0.0, result.sim_time - (snap.time if snap and result.ticks else start))  # from start (0: the loop's)
    if getattr(result, "ended_by", None):
        say(f"{result.ended_by[0]} ended the run at t = {result.ended_by[1]:.6g} s (the FMU asked to terminate the simulation)")
    shown = f"{simulated:.2f}" if abs(simulated - round(simulated, 2)) < 1e-9 else f"{simulated:.6g}"  # never rounded
    say(f"{shown} s simulated in {seconds(result.wall)} ({speed(simulated, result.wall)})"
        + (f", from t = {snap.time:.3f} s" if snap else f", from t = {start:g} s" if start else ""))
    if result.metrics and result.ticks:
        what, values = thesis
        say(f"{'metric':>14} {'value':>12}" + (f"  thesis ({what})" if values else ""))
        for k, v in result.metrics.items():
            say(f"{k:>14} {v:>12.6g}" + (f"  {values[k]:>10.6g}" if values and k in values else ""))
        if what and values is None:
            say(f"note: {what}")
    if monitor is not None and monitor.results:
        from .verdict_table import table

        say("requirements:")
        say("\n".join(table(monitor.results)))
    if pacer is not None:
        say(pacer.summary())
    if log is None or log.is_file():
        say(f"log: {log}" if log else "log: none (--no-log)")


def _outcome(options: RunOptions, opts, meta: dict, result, log: Path | None, monitor, say: Say) -> Outcome:
    """A failed run's one line (exit 1, or 128 + the signal), else the plots and the requirements' verdicts (exit 1 on a
    FAIL, 3 on an INCONCLUSIVE or ZERO without a FAIL)."""
    from ..errors import failure_line
    from ..views.plot import plot_run

    if result.error:
        failure = failure_line(result.error, log, result.sim_time)
        files = _failed_run_plots(options, log, say)
        return Outcome(128 + result.signal if result.signal else 1, opts, meta, result, log, files, failure)
    files = []
    if not options.no_plots and log is not None:
        files = plot_run(log)
        say(f"plots: {', '.join(str(f) for f in files)}")
    verdicts = tuple(monitor.results) if monitor is not None else ()
    judged = {r.verdict for r in verdicts}  # as check's exit: 1 a FAIL, 3 none failed but not all passed (docs/exit_codes.md)
    code = 1 if "FAIL" in judged else 3 if judged - {"PASS"} else 0
    return Outcome(code, opts, meta, result, log, files, None, verdicts)


def _failed_run_plots(options: RunOptions, log: Path | None, say: Say) -> list[Path]:
    """A run that ended early still gets its figures, of what its log holds (a diverged one scaled to where its signals
    were sane: plot.scale_to_sane); a log too damaged to draw gets none, said in one line."""
    from ...engine.log.reader import DamagedLog
    from ..views.plot import plot_intact

    if options.no_plots or log is None or not log.is_file():
        return []
    try:
        files, _ = plot_intact(log)
    except (DamagedLog, ValueError, OSError) as err:
        say(f"plots: none ({str(err).splitlines()[0]})")
        return []
    say(f"plots: {', '.join(str(f) for f in files)}")
    return files


def _run_inputs(case: Case, options: RunOptions, log: Path | None) -> list[tuple[str, Path | None]]:
    """What a run reads (and its log, which the report judges): none of them may be its report."""
    controller = case.controller if isinstance(case.controller, Path) or str(case.controller).endswith(".fmu") else None
    return [("the run's log", log), ("the requirement file", options.requirements), ("the snapshot", options.from_snapshot),
            ("the token file", options.token_file), ("the faults file", case.faults), ("the wind file", case.wind),
            ("the system file", case.system), ("the controller FMU", Path(controller) if controller else None),
            ("the trajectory file", case.trajectory if isinstance(case.trajectory, Path) else None)]


def _report(case: Case, options: RunOptions, system, outcome: Outcome, monitor, say: Say) -> None:
    """--report FILE: the run as a one-test report (its requirements, figures, environment, replay command)."""
    from ..evidence import Report, environment_of_system, test_of_log, write_report
    from ..evidence.model import Test
    from .command_line import run_command

    command = run_command(case, options)
    results = list(monitor.results) if monitor is not None else []
    if outcome.log is not None and outcome.log.is_file():
        test = test_of_log(outcome.log, results, options.requirements)
        test.command, test.error = command, outcome.failure
    else:
        test = Test(outcome.opts.run_name(), command, dict(outcome.metadata), None, results,
                    dict(outcome.result.metrics), outcome.failure)
    declared = list(monitor.requirements) if monitor is not None else []
    tables = []
    if outcome.result.profile is not None:  # --profile: where the ticks' time went
        from ..evidence.model import Table

        header, rows, note = outcome.result.profile.table()
        tables.append(Table("Where the ticks' time went (--profile)", header, tuple(rows), note))
    report = Report(f"Run {test.name}", "run", [test], environment_of_system(system), declared=declared, tables=tables)
    say(f"report: {write_report(report, options.report, inputs=_run_inputs(case, options, outcome.log))}")


def _monitor(options: RunOptions, system, span: float):
    """The requirements' observer, its signals checked against the FMUs' outputs before anything runs."""
    if options.requirements is None:
        if options.stop_on_violation:
            raise UserError("--stop-on-violation needs --requirements")
        return None
    from ...engine.fmi.model_description import read_fmu
    from ...engine.requirement.files import check_horizons, check_signals, load
    from ...engine.requirement.observer import RequirementObserver

    reqs = load(options.requirements)
    check_horizons(reqs, span, "this run")  # as check refuses it: a window past the run's end can never be decided
    available = {}
    for inst in system.instances:
        for v in read_fmu(inst.fmu, inst.name).modelVariables:
            if v.causality == "output":
                available[f"{inst.name}.{v.name}"] = "number" if v.type in ("Real", "Integer", "Boolean") else f"a {v.type}"
    check_signals(reqs, available, "the run's outputs")
    return RequirementObserver(reqs, stop_on_violation=options.stop_on_violation, log_every=options.log_every)

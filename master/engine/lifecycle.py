"""A run's life cycle, once for every face: build or restart an execution, run it, finish the observers, then close
the execution when the run ended fatally or keep it for the next run.

A RunPlan says what one run is (the system, the stop time, the log, the observers, the policies); an ExecutionPool,
owned by whoever runs many cases (a campaign or falsification worker, a test session), keeps executions between runs,
one per system structure: a run of the same structure restarts one (fmi2Reset and new parameters, faults, observers;
Execution.restart), another instantiates. `run_plan(plan, pool)` is the one function that runs a plan; without a
pool, the execution is made for the run and closed after it.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from .execution import Execution, IsolationPolicy
from .log.logger import CHUNK_TICK_BY_TICK, McapLogger
from .metrics import Metrics
from .observers import Progress
from .system import System


@dataclass
class RunResult:
    metrics: dict[str, float]
    log: Path | None
    ticks: int
    sim_time: float
    wall: float
    error: str | None
    signal: int | None = None  # the signal that interrupted the run (SIGINT 2, SIGTERM 15)
    failure: BaseException | None = None  # what ended the run early (one of the plan's outcomes), its own words
    setup: float = 0.0  # s from the plan's start to the first step (instantiation or restart)
    ended_by: tuple[str, float] | None = None  # (instance, time): an FMU ended the run there (not an error: edges.py)
    profile: object = None  # profile.RunProfile of the run's ticks (the plan's profile on), else None


@dataclass(frozen=True)
class RunPlan:
    """One run. log: the MCAP log (None: none), written every log_every-th step of each FMU, with the derived
    channels (mcap_log.DerivedChannel) and metadata; metrics: their table goes into the result and the log's summary;
    observers: more observers, after the log; progress: a progress line on stderr. isolate(fmu, md) picks the FMUs
    that run in worker processes of their own, each call watched for step_timeout s. realtime (realtime.Pacer)
    paces the ticks. resume (snapshot.Snapshot) continues a run from where it was taken; checkpoints [(t, fn)] call
    fn(execution) when the run reaches t (t <= stop). announce(execution) is called once the system is checked,
    before any FMU is loaded. segment: the run advances in calls that end on whole multiples of that many ticks (an
    observer's decision points). outcomes: the exceptions that end the run with its error line (the execution kept
    unless an FMU is fatal); any other propagates, the execution closed. when: the error line says the time
    (" (at t = ... s)") unless it does already; False: the exception's own words (a campaign's rows). profile: the
    result says where the ticks' time went (profile.py)."""

    system: System
    stop: float
    log: Path | None = None
    metadata: dict | None = None
    channels: tuple = ()
    log_every: int = 1
    metrics: Metrics | None = None
    observers: tuple = ()
    progress: bool = False
    isolate: IsolationPolicy | None = None
    step_timeout: float | None = None
    realtime: object = None
    resume: object = None
    checkpoints: tuple = ()
    announce: Callable | None = None
    segment: int | None = None
    outcomes: tuple[type[BaseException], ...] = (KeyboardInterrupt, Exception)
    when: bool = True
    profile: bool = False  # time every step and tick (profile.py): the result's profile


def structure(system: System, isolate: IsolationPolicy | None, step_timeout: float | None) -> tuple:
    """What two systems must share for one execution to run both (restart sets parameters and faults): the FMUs,
    their instances, periods and hosts, the connections, the tick and where the FMUs run."""
    instances = tuple((i.name, str(i.fmu), i.period, i.timing, i.remote, str(i.token_file), i.fmi) for i in system.instances)
    wires = tuple((c.source, c.target, c.delay) for c in system.connections)
    return system.tick, system.start_time, instances, wires, system.auto_connect, system.fmu_end, isolate, step_timeout


class ExecutionPool:
    """Executions kept between runs, one per system structure; owned by whoever runs many cases. keep=False: none is
    kept (a run's execution is closed after it)."""

    def __init__(self, keep: bool = True) -> None:
        self.keep = keep
        self.instantiated = 0  # executions this pool made (a restart makes none)
        self._idle: dict[tuple, Execution] = {}

    def __len__(self) -> int:
        return len(self._idle)

    def executions(self) -> list[Execution]:
        """The executions waiting for a run."""
        return list(self._idle.values())

    def take(self, system: System, isolate: IsolationPolicy | None, step_timeout: float | None) -> Execution | None:
        """The execution of this structure, taken out of the pool (None: there is none)."""
        return self._idle.pop(structure(system, isolate, step_timeout), None)

    def build(self, system: System, observers, isolate: IsolationPolicy | None, step_timeout: float | None) -> Execution:
        """A new execution of the system (checked, nothing loaded yet)."""
        execution = Execution(system, observers, isolate=isolate, step_timeout=step_timeout)
        self.instantiated += 1
        return execution

    def give_back(self, execution: Execution) -> None:
        """After a run: kept for the next run of its structure, unless an FMU is fatal (or the pool keeps none)."""
        key = structure(execution.system, execution.isolate, execution.step_timeout)
        if not self.keep or key in self._idle or any(i.fatal for i in execution.instances.values()):
            execution.close()
        else:
            self._idle[key] = execution

    def prepare(self, system: System, isolate: IsolationPolicy | None = None, step_timeout: float | None = None) -> bool:
        """Instantiate the system ahead of its runs (the first then restarts it). Never raises (False: not prepared;
        the run meets the problem again and reports it)."""
        if structure(system, isolate, step_timeout) in self._idle:
            return True
        execution = None
        try:
            execution = self.build(system, [], isolate, step_timeout)
            execution.instantiate()
        except Exception:
            if execution is not None:
                try:
                    execution.close()
                except Exception:
                    pass
            return False
        self.give_back(execution)
        return True

    def close(self) -> None:
        """Close every execution kept."""
        idle, self._idle = self._idle, {}
        for execution in idle.values():
            execution.close()


def run_plan(plan: RunPlan, pool: ExecutionPool | None = None) -> RunResult:
    """Run a plan on the pool's execution of its structure (restarted) or a new one; its result. What fails while the
    system is described or the snapshot checked (before anything loads) propagates; see RunPlan for the rest."""
    pool = pool if pool is not None else ExecutionPool(keep=False)
    logger = McapLogger(plan.log, metadata=plan.metadata, log_every=plan.log_every, derived=plan.channels,
                        chunk_size=CHUNK_TICK_BY_TICK if plan.realtime is not None else None) if plan.log is not None else None
    observers = [*([logger] if logger else []), *plan.observers]
    if plan.metrics is not None:
        observers.append(plan.metrics)
    started = time.perf_counter()  # the run's one clock: the bar's and the result's wall (loading included)
    progress = Progress(plan.stop, started=started) if plan.progress else None
    if progress is not None:
        observers.append(progress)
    ex = pool.take(plan.system, plan.isolate, plan.step_timeout)
    fresh = ex is None
    if fresh:
        ex = pool.build(plan.system, observers, plan.isolate, plan.step_timeout)
        if plan.resume is not None:
            from .snapshot import check

            check(ex, plan.resume)  # another system, another build, a fixed parameter: refused before anything loads
    if plan.announce is not None:
        plan.announce(ex)
    error, signum, failure, setup = None, None, None, 0.0
    kept = False
    profiler, profile = None, None
    try:
        if fresh:
            ex.instantiate(plan.resume)
        else:
            ex.restart({i.name: i.parameters for i in plan.system.instances}, observers, plan.system.faults, resume=plan.resume)
        setup = time.perf_counter() - started
        if plan.profile:
            from .profile import Profiler

            profiler = Profiler(ex)
            profiler.start()
        _advance(ex, plan)
        kept = True
    except plan.outcomes as err:
        setup = setup or time.perf_counter() - started
        failure, kept = err, True
        if isinstance(err, KeyboardInterrupt):
            signum = getattr(err, "signum", 2)
            error = f"interrupted by {'SIGTERM' if signum == 15 else 'SIGINT'} at t = {ex.time:.3f} s"
        else:
            error = f"{err} (at t = {ex.time:.3f} s)" if plan.when and "t=" not in str(err) else str(err)
    finally:
        if profiler is not None and ex.loop is not None:  # what ran of the run, failed or not
            profile = profiler.stop()
        if plan.metrics is not None and logger is not None:
            logger.final_metadata["metrics"] = {**plan.metrics.table(), "ticks": ex.ticks_done, "complete": error is None}
        if plan.realtime is not None and logger is not None:
            logger.final_metadata["realtime"] = plan.realtime.statistics()
        ex.finish(error)
        if kept:
            pool.give_back(ex)  # closed there after fmi2Fatal: the next run starts afresh
        else:
            ex.close(error)  # a failure outside the run's outcomes
    wall = time.perf_counter() - started
    if progress is not None:
        progress.done(ex.time, wall)  # the bar ends on the figures the result holds
    return RunResult(plan.metrics.table() if plan.metrics else {}, Path(plan.log) if plan.log is not None else None,
                     ex.ticks_done, ex.time, wall, error, signum, failure, setup, getattr(ex, "ended_by", None), profile)


def _advance(ex: Execution, plan: RunPlan) -> None:
    """To the stop time, through the checkpoints; with plan.segment, in calls that end on its multiples; then the run's
    end (Execution.end: a shorter last step or the nearest tick, and the closing samples)."""
    for t, fn in sorted(plan.checkpoints, key=lambda c: c[0]):
        if t <= plan.stop:
            ex.run(t, plan.realtime)
            fn(ex)
    if plan.segment is not None:
        tick = ex.system.tick
        n = ex.stop_plan(plan.stop).ticks - 1  # the last tick, possibly shortened, is the end's
        while ex.ticks_done < n:
            ex.run(ex.system.start_time + min(n, (ex.ticks_done // plan.segment + 1) * plan.segment) * tick, plan.realtime)
    ex.end(plan.stop, plan.realtime)

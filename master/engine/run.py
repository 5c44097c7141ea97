"""Run a system: execution + MCAP logger + metrics + progress, with clean failure handling.

Any failure (an FMU error, a diverging plant, Ctrl-C) stops the run with one line; the MCAP
log is finalized first, so it is readable up to the last completed step.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

from .execution import Execution, IsolationPolicy
from .mcap_log import CHUNK_TICK_BY_TICK, McapLogger
from .observers import Metrics, Progress
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


def run_system(system: System, stop: float, log: Path | None, metrics: Metrics | None = None, progress: bool = True,
               metadata: dict | None = None, channels=(), observers_extra=(), log_every: int = 1,
               isolate: IsolationPolicy | None = None, step_timeout: float | None = None, announce=None,
               realtime=None, resume=None, checkpoints=()) -> RunResult:
    """Run to stop; log to MCAP unless log is None (metrics only), every log_every-th step of each FMU, with the
    derived channels given (mcap_log.DerivedChannel: a 3D scene, say). isolate(fmu, md) picks the FMUs that run
    in worker processes of their own (isolation/process.py). announce(execution), if given, is called once the
    system is checked, before any FMU is loaded. realtime (realtime.Pacer) paces the ticks; its statistics go into
    the log's "realtime" record. resume (snapshot.Snapshot) continues a run from where it was taken; checkpoints
    [(t, fn)] call fn(execution) when the run reaches t (a snapshot, say)."""
    logger = McapLogger(log, metadata=metadata, log_every=log_every, derived=channels,
                        chunk_size=CHUNK_TICK_BY_TICK if realtime is not None else None) if log is not None else None
    observers = [*([logger] if logger else []), *observers_extra]
    if metrics is not None:
        observers.append(metrics)
    if progress:
        observers.append(Progress(stop))
    ex = Execution(system, observers, isolate=isolate, step_timeout=step_timeout)
    if resume is not None:
        from .snapshot import check

        check(ex, resume)  # another system, another build, a fixed parameter: refused before anything loads
    if announce is not None:
        announce(ex)
    started = time.perf_counter()
    error, signum = None, None
    try:
        ex.instantiate(resume)
        for t, fn in sorted(checkpoints, key=lambda c: c[0]):
            if t <= stop:  # at the stop time: the run's end state (the final run below then has nothing left to do)
                ex.run(t, realtime)
                fn(ex)
        ex.run(stop, realtime)
    except KeyboardInterrupt as err:
        signum = getattr(err, "signum", 2)
        error = f"interrupted by {'SIGTERM' if signum == 15 else 'SIGINT'} at t = {ex.time:.3f} s"
    except Exception as err:
        error = f"{err} (at t = {ex.time:.3f} s)" if "t=" not in str(err) else str(err)
    finally:
        if metrics is not None and logger is not None:
            logger.final_metadata["metrics"] = {**metrics.table(), "ticks": ex.ticks_done, "complete": error is None}
        if realtime is not None and logger is not None:
            logger.final_metadata["realtime"] = realtime.statistics()
        ex.close(error)
    return RunResult(metrics.table() if metrics else {}, Path(log) if log is not None else None, ex.ticks_done, ex.time,
                     time.perf_counter() - started, error, signum)


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised where the run is: handled as Ctrl-C is (the log is finalized), reported as SIGTERM."""

    signum = 15


def terminate_like_interrupt() -> None:
    """Make SIGTERM stop a run the way Ctrl-C does (the main thread only)."""
    import signal

    def handler(signum, frame):
        raise Terminated()
    try:
        signal.signal(signal.SIGTERM, handler)
    except ValueError:  # not the main thread: leave the default
        pass

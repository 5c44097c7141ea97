"""Run a system once: execution + MCAP logger + metrics + progress, with clean failure handling (lifecycle.py).

Any failure (an FMU error, a diverging plant, Ctrl-C) stops the run with one line; the MCAP
log is finalized first, so it is readable up to the last completed step.
"""

from __future__ import annotations

from pathlib import Path

from .execution import IsolationPolicy
from .lifecycle import RunPlan, RunResult, run_plan
from .metrics import Metrics
from .system import System

__all__ = ["RunPlan", "RunResult", "run_plan", "run_system", "terminate_like_interrupt", "Terminated"]


def run_system(system: System, stop: float, log: Path | None, metrics: Metrics | None = None, progress: bool = True,
               metadata: dict | None = None, channels=(), observers_extra=(), log_every: int = 1,
               isolate: IsolationPolicy | None = None, step_timeout: float | None = None, announce=None,
               realtime=None, resume=None, checkpoints=()) -> RunResult:
    """One run on an execution of its own (closed after it): the keywords are RunPlan's (lifecycle.py), kept for the
    callers that run one system once."""
    return run_plan(RunPlan(system, stop, log, metadata, tuple(channels), log_every, metrics, tuple(observers_extra), progress,
                            isolate, step_timeout, realtime, resume, tuple(checkpoints), announce))


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

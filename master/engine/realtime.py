"""Real-time pacing: every tick starts at an absolute deadline on the monotonic clock, t0 + k T / factor.

The C tick loop sleeps until each deadline (clock_nanosleep with TIMER_ABSTIME: no drift from sleeping
T per tick) and records how late each tick started. A tick that arrives after its deadline is an
overrun: the tick before it took longer than its slot. The pacer keeps every tick's lateness for the
statistics (count, worst, p50/p99/p99.9) and can stop the run once the overruns exceed a budget.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .errors import ExecutionError

LEAD_IN = 0.001  # s from the first look at the clock to tick 0: the first deadline is ahead, not already missed


class OverrunBudgetExceeded(ExecutionError):
    """More ticks missed their deadline than the run allowed (--max-overruns)."""


@dataclass
class Pacer:
    factor: float = 1.0  # simulated seconds per wall second
    max_overruns: int | None = None  # stop the run after more overruns than this
    lateness: list[np.ndarray] = field(default_factory=list)
    overruns: int = 0
    _start_ns: int | None = None
    _first_tick: int = 0

    def __post_init__(self) -> None:
        if not (self.factor > 0 and np.isfinite(self.factor)):
            raise ValueError(f"the real-time factor must be a positive number, got {self.factor!r}")

    def prepare(self, plan, first_tick: int, lateness: np.ndarray, overrun: np.ndarray) -> None:
        """Before a call of the tick loop: the deadlines (fixed at the first call), where lateness goes."""
        if self._start_ns is None:
            from .native.kernel import library

            self._start_ns = int(library().tl_monotonic_ns() + LEAD_IN * 1e9)
            self._first_tick = first_tick
        plan.realtime_factor = self.factor
        plan.realtime_start_ns = self._start_ns
        plan.realtime_first_tick = self._first_tick
        plan.lateness = lateness.ctypes.data
        plan.overrun = overrun.ctypes.data

    def took(self, lateness: np.ndarray, overrun: np.ndarray, tick: float, next_tick: int, start: float = 0.0) -> None:
        """After a call: keep its ticks' lateness; stop the run when the overruns exceed the budget."""
        self.lateness.append(lateness.copy())
        self.overruns += int(np.count_nonzero(overrun))
        if self.max_overruns is not None and self.overruns > self.max_overruns:
            raise OverrunBudgetExceeded(f"real time: {self.overruns} ticks missed their deadline, more than the "
                                        f"--max-overruns {self.max_overruns} allowed (at t = {start + next_tick * tick:.3f} s)")

    def statistics(self) -> dict[str, float]:
        """ticks, overruns, worst lateness and its percentiles (s)."""
        late = np.concatenate(self.lateness) if self.lateness else np.zeros(0)
        if not len(late):
            return {"factor": self.factor, "ticks": 0, "overruns": 0}
        p50, p99, p999 = np.percentile(late, [50, 99, 99.9])
        return {"factor": self.factor, "ticks": int(len(late)), "overruns": self.overruns, "worst_lateness": float(late.max()),
                "lateness_p50": float(p50), "lateness_p99": float(p99), "lateness_p999": float(p999)}

    def summary(self) -> str:
        s = self.statistics()
        if not s["ticks"]:
            return f"real time {self.factor:g}x: no tick run"
        return (f"real time {self.factor:g}x: {s['ticks']} ticks, {s['overruns']} overruns; lateness p50 "
                f"{s['lateness_p50'] * 1e3:.3f} ms, p99 {s['lateness_p99'] * 1e3:.3f} ms, p99.9 "
                f"{s['lateness_p999'] * 1e3:.3f} ms, worst {s['worst_lateness'] * 1e3:.3f} ms")

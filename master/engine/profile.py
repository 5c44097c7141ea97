"""Where a run's time goes (`tiltload run --profile`, Result.profile): each FMU's step time (min, median, p99, max)
and share of the run, its isolation's share, the master's own, the log's, and the real-time margin against the
controller's period.

The C tick loop measures it (tl_loop.c, with tl_plan.profile on): two reads of CLOCK_MONOTONIC around every step
(its FMI calls, or the isolated FMU's round trip) and every tick, each time into a fixed histogram of 16 buckets an
octave (6 % wide: the median and p99 are good to 6 %; min and max are exact). An FMU isolated on shared memory has its
host time its own calls (the same clock), so the round trip splits into the FMU's time and the isolation's. Python
times the observers around their calls (the log's is its hand-over to its writer thread; the writing itself runs on
that thread, beside the loop). The master's share is the ticks' time outside the FMUs' steps plus what no other part
measured (its Python between two calls of the loop). Off, the profile costs one branch per tick and per step.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from .native.codes import Dimension

BUCKETS = int(Dimension.PROFILE_BUCKETS)
SUB = 1 << int(Dimension.PROFILE_OCTAVE_BITS)
INT64_MAX = np.iinfo(np.int64).max


def bucket_bounds(b: int) -> tuple[float, float]:
    """The nanoseconds [low, high) of histogram bucket b (tl_loop.c's profile_add: ns = m 2^e, m in [0.5, 1))."""
    e, s = divmod(b, SUB)
    base = 2.0 ** (e - 1)
    return base * (1 + s / SUB), base * (1 + (s + 1) / SUB)


def quantile(histogram: np.ndarray, q: float, low: float, high: float) -> float:
    """The q-quantile of a histogram's times (ns), its bucket's middle kept within [low, high] (the exact min, max)."""
    total = int(histogram.sum())
    if total == 0:
        return float("nan")
    b = int(np.searchsorted(np.cumsum(histogram), q * total, side="left"))
    lo, hi = bucket_bounds(min(b, BUCKETS - 1))
    return min(max((lo + hi) / 2, low), high)


@dataclass(frozen=True)
class StepTimes:
    """One FMU's steps (or the ticks): their count, min, median, p99 and max in seconds, and their sum."""

    count: int
    min: float
    median: float
    p99: float
    max: float
    total: float

    @classmethod
    def of(cls, histogram: np.ndarray, fastest_ns: int, slowest_ns: int, total_ns: int) -> StepTimes:
        n = int(histogram.sum())
        if n == 0:
            return cls(0, float("nan"), float("nan"), float("nan"), float("nan"), 0.0)
        lo, hi = float(fastest_ns), float(slowest_ns)
        return cls(n, lo * 1e-9, quantile(histogram, 0.5, lo, hi) * 1e-9, quantile(histogram, 0.99, lo, hi) * 1e-9,
                   hi * 1e-9, total_ns * 1e-9)


@dataclass(frozen=True)
class FmuProfile:
    """An FMU's steps: their times (the round trip for an isolated one), its period, the part of the steps its host
    spent in the FMU's own calls (None: not measured apart: in this process it is all of it; on a pipe, unknown)."""

    name: str
    period: float  # s
    steps: StepTimes
    isolated: str | None  # how: "shared memory", "worker process (pipe)", a remote host; None: in this process
    in_fmu: float | None  # s of steps.total spent in the FMU's calls in its host

    @property
    def isolation(self) -> float:
        """s of its steps spent crossing to its host and back (0 in process; the whole round trip when not split)."""
        if self.isolated is None:
            return 0.0
        return self.steps.total - self.in_fmu if self.in_fmu is not None else 0.0


@dataclass(frozen=True)
class RunProfile:
    """The run's time by part, in seconds of wall time (CLOCK_MONOTONIC) over the profiled ticks; shares of `total`."""

    ticks: int
    tick: float  # s, the master's
    total: float  # s, the loop from its first tick to its end (the closing samples included)
    fmus: tuple[FmuProfile, ...]
    tick_times: StepTimes
    log: float  # s in the log's hand-over (main thread)
    observers: float  # s in the other observers (metrics, progress, monitors)
    controller: str | None = None  # the instance whose period the real-time margin is against
    parts: dict[str, float] = field(default_factory=dict)  # every share by label: fmus, isolation, master, log, ...

    def __post_init__(self) -> None:
        parts = {}
        for f in self.fmus:
            parts[f.name] = (f.in_fmu if f.in_fmu is not None else f.steps.total) if f.isolated else f.steps.total
            if f.isolated:
                parts[f"isolation of {f.name}"] = f.isolation
        parts["log"] = self.log
        parts["observers"] = self.observers
        parts["master"] = self.total - sum(parts.values())  # its ticks' own work and its Python between calls
        object.__setattr__(self, "parts", parts)

    @property
    def master_in_ticks(self) -> float:
        """s of the ticks' own time outside every FMU's step (gathers, faults, records, delay line): measured in C."""
        return self.tick_times.total - sum(f.steps.total for f in self.fmus)

    def shares(self) -> dict[str, float]:
        return {k: v / self.total if self.total > 0 else float("nan") for k, v in self.parts.items()}

    def margin(self) -> tuple[float, float, float] | None:
        """(period, p99, max) of the controller's steps: the margin is period - p99 (and period - max)."""
        f = next((f for f in self.fmus if f.name == self.controller), None)
        return None if f is None or f.steps.count == 0 else (f.period, f.steps.p99, f.steps.max)

    def lines(self) -> list[str]:
        """The table `tiltload run --profile` prints."""
        us = 1e6
        shares = self.shares()
        out = [f"profile: {self.ticks} ticks of {self.tick * 1e3:g} ms, {self.total:.3f} s of wall time (CLOCK_MONOTONIC; "
               "median and p99 within 6 %)",
               f"  {'part':<28} {'steps':>7} {'min µs':>9} {'median':>9} {'p99':>9} {'max µs':>9} {'share':>7}"]

        def row(label, s: StepTimes | None, share):
            cells = ["", "", "", "", ""] if s is None else [str(s.count), *(f"{x * us:.1f}" for x in (s.min, s.median, s.p99, s.max))]
            out.append(f"  {label:<28} {cells[0]:>7} {cells[1]:>9} {cells[2]:>9} {cells[3]:>9} {cells[4]:>9} {share:>6.1%}")

        for f in self.fmus:
            row(f.name[:28], f.steps, shares[f.name])
            if f.isolated:
                share = shares[f"isolation of {f.name}"]
                out.append(f"  {'  isolation':<28} {'':>7} {'':>9} {'':>9} {'':>9} {'':>9} {share:>6.1%}  ({f.isolated}; the "
                           "steps' times are round trips)" if f.in_fmu is not None else
                           f"  {'':<28} ({f.isolated}: the round trip's FMU and crossing not told apart, all in its share)")
        row("master", None, shares["master"])
        row("log", None, shares["log"])
        row("observers", None, shares["observers"])
        row("tick (all of the above in C)", self.tick_times, self.tick_times.total / self.total if self.total > 0 else float("nan"))
        m = self.margin()
        if m is not None:
            period, p99, worst = m
            out.append(f"real-time margin: the {self.controller}'s period is {period * 1e3:g} ms; its step takes "
                       f"{p99 * us:.1f} µs at p99 ({p99 / period:.2%} of it, margin {(period - p99) * 1e3:.3f} ms), "
                       f"{worst * us:.1f} µs at worst (margin {(period - worst) * 1e3:.3f} ms)")
        t = self.tick_times
        if t.count:
            out.append(f"the whole tick: {t.p99 * us:.1f} µs at p99, {t.max * us:.1f} µs at worst, against {self.tick * 1e3:g} ms")
        return out

    def table(self) -> tuple[tuple[str, ...], list[tuple[str, ...]], str]:
        """(header, rows, note) of the figures `lines` prints, as text cells (a report's table)."""
        shares = self.shares()

        def cells(s: StepTimes | None) -> tuple[str, ...]:
            return ("",) * 5 if s is None else (str(s.count), *(f"{x * 1e6:.1f}" for x in (s.min, s.median, s.p99, s.max)))

        rows = []
        for f in self.fmus:
            rows.append((f.name, *cells(f.steps), f"{shares[f.name]:.1%}"))
            if f.isolated and f.in_fmu is not None:
                rows.append((f"{f.name}: isolation ({f.isolated})", *cells(None), f"{shares[f'isolation of {f.name}']:.1%}"))
        rows += [(part, *cells(None), f"{shares[part]:.1%}") for part in ("master", "log", "observers")]
        rows.append(("tick", *cells(self.tick_times), f"{self.tick_times.total / self.total:.1%}" if self.total > 0 else ""))
        note = " ".join(self.lines()[-2:]) if self.margin() is not None else ""
        return ("part", "steps", "min µs", "median µs", "p99 µs", "max µs", "share"), rows, note

    def as_dict(self) -> dict:
        """Plain numbers (the report's, the log's), times in seconds."""
        def times(s: StepTimes) -> dict:
            return {"count": s.count, "min": s.min, "median": s.median, "p99": s.p99, "max": s.max, "total": s.total}
        return {"ticks": self.ticks, "tick": self.tick, "total": self.total, "shares": self.shares(),
                "fmus": {f.name: {"period": f.period, "isolated": f.isolated, "in_fmu": f.in_fmu, **times(f.steps)}
                         for f in self.fmus},
                "tick_times": times(self.tick_times), "controller": self.controller}


class Profiler:
    """Turns the loop's profile on for the ticks of one run and gathers the parts (RunProfile) at its end."""

    def __init__(self, execution, controller: str | None = "controller") -> None:
        self.ex = execution
        self.controller = controller
        self.observed = {"log": 0, "observers": 0}  # ns
        self._started = 0
        self._ticks0 = 0

    def start(self) -> None:
        """Before the first profiled tick (the execution instantiated or restarted)."""
        self.ex.profiler = self
        self.ex.loop.profile_from_now()
        self._ticks0 = self.ex.ticks_done
        self._started = time.monotonic_ns()  # CLOCK_MONOTONIC, as the loop's

    def observe(self, observer, ns: int) -> None:
        """An observer took ns in its call (deliver)."""
        self.observed["log" if getattr(observer, "is_log", False) else "observers"] += ns

    def stop(self) -> RunProfile:
        total = (time.monotonic_ns() - self._started) * 1e-9
        self.ex.profiler = None
        loop = self.ex.loop
        loop.profile_off()
        fmus = []
        for i, name in enumerate(loop.names):
            c = loop.instances[i]
            steps = StepTimes.of(loop.histograms[i], c.fastest_ns, c.slowest_ns, loop.step_ns[i])
            slave = loop.slaves[i]
            how = isolation_of(slave, loop.paths[name])
            in_fmu = loop.host_ns[i] * 1e-9 if how == "shared memory" else None
            fmus.append(FmuProfile(name, self.ex.every[name] * self.ex.system.tick, steps, how, in_fmu))
        p = loop.plan
        ticks = StepTimes.of(loop.tick_histogram, p.fastest_tick_ns, p.slowest_tick_ns, p.tick_ns)
        controller = self.controller if self.controller in loop.names else None
        return RunProfile(self.ex.ticks_done - self._ticks0, self.ex.system.tick, total, tuple(fmus), ticks,
                          self.observed["log"] * 1e-9, self.observed["observers"] * 1e-9, controller)


def isolation_of(slave, path: str) -> str | None:
    """How a slave is isolated, by the loop's path for it: None in this process."""
    if path.startswith("kernel: shared memory"):
        return "shared memory"
    if not path.startswith("callback"):
        return None
    where = getattr(getattr(slave, "host", None), "where", None)
    return f"tiltload serve at {where}" if where else "worker process (pipe)" if hasattr(slave, "host") else None

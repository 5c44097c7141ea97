"""Discrete-time quantitative robustness of STL (Donzé & Maler 2010; Fainekos & Pappas 2009) on a uniformly sampled trace.

rho(l > r) = l - r, rho(l < r) = r - l (<= and >= alike), rho(l == r) = -|l - r|, rho(l !== r) = |l - r|; not negates;
and = min, or = max, implies = max(-rho(p), rho(q)); always[a:b] = min over the samples t' in [t + a, t + b] (closed),
eventually = max; p until[a:b] q = max over t' in [t + a, t + b] of min(rho(q, t'), min over t'' in [t, t') of rho(p, t''))
(the discrete form rtamt uses). Time bounds are whole ticks: a bound within 1e-9 tick of a multiple of the period is that
multiple, else the window holds the ticks inside it. An operator without interval runs to the end of the trace.

Three evaluations of the same tree: "value" treats the samples past the end of the trace as absent (rtamt's finite-trace
semantics: a truncated window is the min/max of what there is); "lower" and "upper" bound the robustness over every
way the trace could go on (an unknown sample is -inf, resp. +inf; `not` swaps the bounds). A run that covers the
formula's horizon has value = lower = upper at its start. Windowed min/max are O(n) (windows.py); bounded until is
O(n w) in vectorized passes (w: its window in ticks); unbounded until is O(n).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .syntax import Always, And, Compare, Const, Eventually, Implies, Not, Or, Signal, StlError, Until, bounded_horizon, signals
from .windows import sliding_min

_SLACK = 1e-9  # of a tick: a time bound this close to a whole number of ticks is that number


@dataclass
class Trace:
    """Samples on a uniform grid: times[i] = times[0] + i * period, and each signal's value at each sample."""

    times: np.ndarray
    signals: dict[str, np.ndarray]
    period: float

    @classmethod
    def uniform(cls, times, signals: dict, period: float | None = None) -> Trace:
        times = np.asarray(times, dtype=float)
        if period is None:
            if len(times) < 2:
                raise StlError("a trace of one sample has no period: give it")
            period = (times[-1] - times[0]) / (len(times) - 1)
        if len(times) > 1 and np.max(np.abs(np.diff(times) - period)) > 1e-6 * period:
            raise StlError(f"the samples are not uniformly spaced (period {period:g} s): STL's discrete time needs the tick")
        data = {k: np.asarray(v, dtype=float) for k, v in signals.items()}
        for k, v in data.items():
            if v.shape != times.shape:
                raise StlError(f"signal {k} has {len(v)} samples for {len(times)} times")
        return cls(times, data, float(period))

    def __len__(self) -> int:
        return len(self.times)

    def ticks(self, seconds: float) -> int:
        """A window's start in ticks: the first tick at or after the bound."""
        return max(0, math.ceil(seconds / self.period - _SLACK))

    def ticks_end(self, seconds: float) -> int:
        """A window's end in ticks: the last tick at or before the bound (len(self) for no bound: the end of the trace)."""
        return len(self) if math.isinf(seconds) else math.floor(seconds / self.period + _SLACK)


_FLIP = {"value": "value", "lower": "upper", "upper": "lower"}


class Evaluator:
    """The robustness of every node of a formula at every sample, in one of three modes, each computed once.

    final: the trace is the whole run (an operator without interval ends with it); False for a run still going."""

    def __init__(self, trace: Trace, final: bool = True) -> None:
        self.trace, self.final = trace, final
        self._memo: dict[tuple[int, str], tuple[object, np.ndarray]] = {}

    def __call__(self, node, mode: str = "value") -> np.ndarray:
        key = (id(node), mode)
        hit = self._memo.get(key)
        if hit is None:  # the node is kept with its value: a freed tree's id, reused by a new node, must not hit
            hit = self._memo[key] = (node, self._eval(node, mode))
        return hit[1]

    def _pads(self, mode: str, unbounded: bool) -> tuple[float, float]:
        """(what an absent sample is for a min, for a max): neutral for the value, unknown for a bound."""
        if mode == "value" or (unbounded and self.final):
            return np.inf, -np.inf
        v = -np.inf if mode == "lower" else np.inf
        return v, v

    def value(self, node) -> np.ndarray:
        if isinstance(node, Signal):
            try:
                return self.trace.signals[node.name]
            except KeyError:
                raise StlError(f"no signal {node.name} in the trace") from None
        if isinstance(node, Const):
            return np.full(len(self.trace), node.value)
        args = [self.value(a) for a in node.args]
        with np.errstate(divide="ignore", invalid="ignore"):
            if node.op == "+":
                return args[0] + args[1]
            if node.op == "-":
                return args[0] - args[1]
            if node.op == "*":
                return args[0] * args[1]
            if node.op == "/":
                return args[0] / args[1]
        if node.op == "neg":
            return -args[0]
        return np.abs(args[0])

    def _eval(self, node, mode: str) -> np.ndarray:
        if isinstance(node, Compare):
            left, right = self.value(node.left), self.value(node.right)
            if node.op in ("<", "<="):
                return right - left
            if node.op in (">", ">="):
                return left - right
            if node.op == "==":
                return -np.abs(left - right)
            return np.abs(left - right)
        if isinstance(node, Not):
            return -self(node.arg, _FLIP[mode])
        if isinstance(node, And):
            return np.minimum(self(node.left, mode), self(node.right, mode))
        if isinstance(node, Or):
            return np.maximum(self(node.left, mode), self(node.right, mode))
        if isinstance(node, Implies):
            return np.maximum(-self(node.left, _FLIP[mode]), self(node.right, mode))
        if isinstance(node, (Always, Eventually)):
            lo, hi = self.trace.ticks(node.a), self.trace.ticks_end(node.b)
            pad_min, pad_max = self._pads(mode, math.isinf(node.b))
            x = self(node.arg, mode)
            if lo > hi:
                return np.full(len(x), pad_min if isinstance(node, Always) else pad_max)
            if isinstance(node, Always):
                return sliding_min(x, lo, hi, pad_min)
            return -sliding_min(-x, lo, hi, -pad_max)
        if isinstance(node, Until):
            return self._until(node, mode)
        raise StlError(f"{type(node).__name__} is an expression, not a formula: compare it (e.g. > 0)")

    def _until(self, node, mode: str) -> np.ndarray:
        p, q = self(node.left, mode), self(node.right, mode)
        n = len(p)
        lo, hi = self.trace.ticks(node.a), self.trace.ticks_end(node.b)
        pad_p, pad_q = (np.inf, -np.inf) if mode == "value" or (math.isinf(node.b) and self.final) else self._pads(mode, False)
        if math.isinf(node.b):  # to the end: U[i] = max(q[i], min(p[i], U[i + 1])) backwards, then the start shifted by lo
            u = _until_to_end(p.tolist(), q.tolist(), pad_q)
            first = np.full(n, pad_q if lo else np.inf)  # U0 at i + lo (the tail past the end is pad_q)
            first[:max(0, n - lo)] = u[lo:]
            if lo == 0:
                return first
            return np.minimum(sliding_min(p, 0, lo - 1, pad_p), first)
        out = np.full(n, -np.inf)
        run = np.full(n, np.inf)  # min of p over [i, i + d)
        for d in range(hi + 1):  # O(n w): w vector passes (Donzé et al. 2013 give O(n); the windows here are short)
            if d >= lo:
                out = np.maximum(out, np.minimum(_shifted(q, d, pad_q), run))
            run = np.minimum(run, _shifted(p, d, pad_p))
        return out


def _shifted(x: np.ndarray, d: int, pad: float) -> np.ndarray:
    """y[i] = x[i + d], pad past the end."""
    y = np.full(len(x), pad)
    if d < len(x):
        y[:len(x) - d] = x[d:]
    return y


def _until_to_end(p: list, q: list, tail: float) -> np.ndarray:
    out, nxt = [0.0] * len(p), tail
    for i in range(len(p) - 1, -1, -1):
        nxt = max(q[i], min(p[i], nxt))
        out[i] = nxt
    return np.array(out)


PASS, FAIL, INCONCLUSIVE, ZERO = "PASS", "FAIL", "INCONCLUSIVE", "ZERO"


@dataclass(frozen=True)
class Verdict:
    """The verdict at the trace's start. robustness: the value when decided, else None (bounds: what is known).
    violation: the sample of the first violation (FAIL), its time and the formula's signals there."""

    verdict: str
    robustness: float | None
    bounds: tuple[float, float]
    violation_time: float | None
    violation_values: dict[str, float]
    decided_early: bool = False  # FAIL before the run covered the horizon: no continuation can make it pass


def verdict(formula, trace: Trace, final: bool = True, evaluator: Evaluator | None = None) -> Verdict:
    """PASS (robustness > 0), FAIL (< 0), ZERO (exactly 0: neither) when the trace covers the formula's horizon;
    before that, FAIL if no continuation of the trace can satisfy it, else INCONCLUSIVE (never a pass)."""
    ev = evaluator or Evaluator(trace, final)
    if len(trace) == 0:
        return Verdict(INCONCLUSIVE, None, (-math.inf, math.inf), None, {})
    covered = final and trace.times[-1] - trace.times[0] >= bounded_horizon(formula) - _SLACK * trace.period
    if covered:
        rho = float(ev(formula, "value")[0])
        if rho < 0:
            j = first_violation(formula, ev, 0, "value")
            return Verdict(FAIL, rho, (rho, rho), float(trace.times[j]), _values(formula, trace, j))
        return Verdict(PASS if rho > 0 else ZERO, rho, (rho, rho), None, {})
    low, high = float(ev(formula, "lower")[0]), float(ev(formula, "upper")[0])
    if high < 0:
        j = first_violation(formula, ev, 0, "upper")
        return Verdict(FAIL, None, (low, high), float(trace.times[j]), _values(formula, trace, j), decided_early=True)
    return Verdict(INCONCLUSIVE, None, (low, high), None, {})


def first_violation(node, ev: Evaluator, i: int, mode: str) -> int:
    """The first sample where the formula, violated at sample i, is seen violated: through always (its first violating
    sample in the window) and and (the earliest of its violated sides); any other operator is violated at i."""
    if isinstance(node, Always):
        x = ev(node.arg, mode)
        lo, hi = i + ev.trace.ticks(node.a), min(len(x) - 1, i + ev.trace.ticks_end(node.b))
        bad = np.flatnonzero(x[lo:hi + 1] < 0) if lo <= hi else []
        return first_violation(node.arg, ev, lo + int(bad[0]), mode) if len(bad) else i
    if isinstance(node, And):
        sides = [first_violation(s, ev, i, mode) for s in (node.left, node.right) if ev(s, mode)[i] < 0]
        return min(sides) if sides else i
    return i


def _values(formula, trace: Trace, j: int) -> dict[str, float]:
    return {name: float(trace.signals[name][j]) for name in signals(formula) if name in trace.signals}

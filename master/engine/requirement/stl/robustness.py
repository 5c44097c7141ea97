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
O(n w) in vectorized passes (w: its window in ticks) up to UNTIL_PASSES ticks, O(n) past it; unbounded until is O(n).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .syntax import (
    Always,
    And,
    Arith,
    Compare,
    Const,
    Eventually,
    Implies,
    Not,
    Or,
    Signal,
    StlError,
    Until,
    children,
    postorder,
)
from .windows import sliding_min

_SLACK = 1e-9  # of a tick: a time bound this close to a whole number of ticks is that number


@dataclass
class Trace:
    """Samples on a uniform grid: times[i] = times[0] + i * period, and each signal's value at each sample; the last
    sample may be off the grid, up to half a period either way (a run that ended with a shorter last step: the
    edges of docs/master.md). A window that reaches the trace's end from a sample holds that last sample."""

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
        gaps = np.diff(times)
        if len(times) > 1 and (np.max(np.abs(gaps[:-1] - period), initial=0.0) > 1e-6 * period
                               or not 0 < gaps[-1] <= 1.5 * period + 1e-6 * period):
            raise StlError(f"the samples are not uniformly spaced (period {period:g} s): STL's discrete time needs the tick")
        data = {k: np.asarray(v, dtype=float) for k, v in signals.items()}
        for k, v in data.items():
            if v.shape != times.shape:
                raise StlError(f"signal {k} has {len(v)} samples for {len(times)} times")
        return cls(times, data, float(period))

    def __len__(self) -> int:
        return len(self.times)

    def ticks(self, seconds: float) -> int:
        """A window's start in ticks: the first tick at or after the bound (any bound past the trace is len + 1: the same
        window, none of its samples there, and no float too large for an int)."""
        return max(0, min(len(self) + 1, math.ceil(min(seconds / self.period, len(self) + 1.0) - _SLACK)))

    def covers(self, seconds: float) -> bool:
        """Whether the trace spans at least this long from its first sample (within the bounds' slack of a tick)."""
        return self.times[-1] - self.times[0] >= seconds - _SLACK * self.period

    def ticks_end(self, seconds: float) -> int:
        """A window's end in ticks: the last tick at or before the bound (len(self) for no bound: the end of the trace;
        a bound past the trace is len(self) too, for the same reason as ticks)."""
        if math.isinf(seconds):
            return len(self)
        k = math.floor(min(seconds / self.period, len(self) + 1.0) + _SLACK)
        n = len(self)
        if n > 1 and k == n - 2 and abs(self.times[-1] - self.times[0] - (n - 1) * self.period) > 1e-6 * self.period \
                and seconds >= self.times[-1] - self.times[0] - _SLACK * self.period:
            k = n - 1  # the last sample off the grid (a shorter last step): a window reaching the end holds it
        return min(n, k)


_FLIP = {"value": "value", "lower": "upper", "upper": "lower"}


class Evaluator:
    """The robustness of every node of a formula at every sample, in one of three modes, each computed once.

    final: the trace is the whole run (an operator without interval ends with it); False for a run still going."""

    def __init__(self, trace: Trace, final: bool = True) -> None:
        self.trace, self.final = trace, final
        self._memo: dict[tuple[int, str], tuple[object, np.ndarray]] = {}

    def __call__(self, node, mode: str = "value") -> np.ndarray:
        key = (id(node), mode)
        if key not in self._memo:  # children first, on an explicit stack: a chain thousands deep is no recursion
            stack = [(node, mode)]
            while stack:
                n, m = stack[-1]
                if (id(n), m) in self._memo:
                    stack.pop()
                    continue
                missing = [(c, cm) for c, cm in _operands(n, m) if (id(c), cm) not in self._memo]
                if missing:
                    stack.extend(reversed(missing))
                    continue
                stack.pop()  # the node is kept with its value: a freed tree's id, reused by a new node, must not hit
                self._memo[(id(n), m)] = (n, self._eval(n, m))
        return self._memo[key][1]

    def at_start(self, node, mode: str = "value") -> float:
        """self(node, mode)[0] (a verdict's question), without the windowed min or max over every sample where the
        formula is an always or an eventually: the min or max of its window at the start alone, the same value (min and
        max only select, so bit for bit but for the sign of a zero among equal samples; a NaN in the window carried as
        numpy's minimum carries it)."""
        if not isinstance(node, (Always, Eventually)) or (id(node), mode) in self._memo or not len(self.trace):
            return float(self(node, mode)[0])
        lo, hi = self.trace.ticks(node.a), self.trace.ticks_end(node.b)
        pad_min, pad_max = self._pads(mode, math.isinf(node.b))
        always = isinstance(node, Always)
        if lo > hi:
            return float(pad_min if always else pad_max)
        x = self(node.arg, mode)
        window = x[lo:hi + 1]  # the samples past the end are the pad, once (hi may pass the end: ticks_end stops there)
        if hi >= len(x) or not window.size:
            window = np.append(window, pad_min if always else pad_max)
        return float(np.min(window) if always else np.max(window))

    def _pads(self, mode: str, unbounded: bool) -> tuple[float, float]:
        """(what an absent sample is for a min, for a max): neutral for the value, unknown for a bound."""
        if mode == "value" or (unbounded and self.final):
            return np.inf, -np.inf
        v = -np.inf if mode == "lower" else np.inf
        return v, v

    def value(self, node) -> np.ndarray:
        """An expression's values at every sample (IEEE arithmetic: x / 0 is infinite, 0 / 0 NaN), bottom up."""
        if isinstance(node, (Signal, Const)):  # the common side of a comparison: no walk
            return self._arith(node, [])
        done: dict[int, np.ndarray] = {}
        for n in postorder(node):
            done[id(n)] = self._arith(n, [done.pop(id(c)) for c in children(n)])
        return done[id(node)]

    def _arith(self, node, args: list) -> np.ndarray:
        if isinstance(node, Signal):
            try:
                return self.trace.signals[node.name]
            except KeyError:
                raise StlError(f"no signal {node.name} in the trace") from None
        if isinstance(node, Const):
            return np.full(len(self.trace), node.value)
        if not isinstance(node, Arith):
            raise StlError("a formula where a value goes: compare values, and combine formulas with and, or, not")
        with np.errstate(all="ignore"):
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
            rho = _compare(node.op, self.value(node.left), self.value(node.right))
            if mode != "value":  # NaN (a NaN sample, 0 / 0, inf - inf): a value not known, bounded as one past the end
                rho = np.where(np.isnan(rho), -np.inf if mode == "lower" else np.inf, rho)
            return rho
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
        if hi - lo > UNTIL_PASSES and not (np.isnan(p).any() or np.isnan(q).any()):
            return _until_long(p, q, lo, hi, pad_p, pad_q)
        reach = hi
        if lo > hi and math.floor(min(node.b / self.trace.period, n + 1.0) + _SLACK) >= lo:
            reach = lo  # the window lies wholly past the trace's end: its first tick stands for all of it (all padding)
        out = np.full(n, -np.inf)
        run = np.full(n, np.inf)  # min of p over [i, i + d)
        # O(n w): w vector passes, w <= n + 1 (ticks_end stops at the trace's end); a longer window: _until_long, O(n)
        for d in range(reach + 1):
            if d >= lo:
                out = np.maximum(out, np.minimum(_shifted(q, d, pad_q), run))
            run = np.minimum(run, _shifted(p, d, pad_p))
        return out


UNTIL_PASSES = 256  # a bounded until's window (ticks) up to which it is w vector passes; past it, O(n) (_until_long)


def _until_long(p: np.ndarray, q: np.ndarray, lo: int, hi: int, pad_p: float, pad_q: float) -> np.ndarray:
    """Bounded until in O(n) for a long window. With w = hi - lo, V(m) = max over j in [m, m + w] of min(q[j], min of p
    over [m, j)) equals min(U(m), max of q over [m, m + w]), U the until to the end (U >= V; and where U's best j lies
    past the window, p's running minimum only falls, so the window's largest q bounds it): min and max only select, so
    the values are the definition's, bit for bit but for the sign of a zero. Then the start shifted by lo, as the
    unbounded until does. Samples without NaN only (numpy carries a NaN through more of them than the window)."""
    n = len(p)
    if lo > hi:
        return np.full(n, -np.inf)
    v = np.minimum(_until_to_end(p.tolist(), q.tolist(), pad_q), -sliding_min(-q, 0, hi - lo, -pad_q))
    first = np.full(n, pad_q)  # V at i + lo: past the end nothing but pad_q
    first[:max(0, n - lo)] = v[lo:]
    return first if lo == 0 else np.minimum(sliding_min(p, 0, lo - 1, pad_p), first)


def _shifted(x: np.ndarray, d: int, pad: float) -> np.ndarray:
    """y[i] = x[i + d], pad past the end."""
    y = np.full(len(x), pad)
    if d < len(x):
        y[:len(x) - d] = x[d:]
    return y


def _until_to_end(p: list, q: list, tail: float) -> np.ndarray:
    out, nxt = [0.0] * len(p), tail
    for i in range(len(p) - 1, -1, -1):
        low = nxt if nxt < p[i] or nxt != nxt else p[i]  # min and max as Python's, but NaN carried as numpy carries it
        nxt = low if low > q[i] or low != low else q[i]
        out[i] = nxt
    return np.array(out)


def _compare(op: str, left: np.ndarray, right: np.ndarray) -> np.ndarray:
    with np.errstate(all="ignore"):  # inf - inf is NaN: a value not known (see Evaluator._eval)
        if op in ("<", "<="):
            return right - left
        if op in (">", ">="):
            return left - right
        if op == "==":
            return -np.abs(left - right)
        return np.abs(left - right)


def _operands(node, mode: str) -> list[tuple[object, str]]:
    """The formula nodes a node's robustness in a mode reads, each with its mode (not and implies' left side swap the
    bounds); a comparison reads expressions, evaluated apart (Evaluator.value)."""
    if isinstance(node, Not):
        return [(node.arg, _FLIP[mode])]
    if isinstance(node, Implies):
        return [(node.left, _FLIP[mode]), (node.right, mode)]
    if isinstance(node, (And, Or, Until)):
        return [(node.left, mode), (node.right, mode)]
    if isinstance(node, (Always, Eventually)):
        return [(node.arg, mode)]
    return []

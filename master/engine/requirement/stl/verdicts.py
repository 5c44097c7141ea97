"""The verdict of a formula at a trace's start (robustness.py evaluates it): PASS, FAIL, ZERO or INCONCLUSIVE, decided as
soon as no continuation can change it, with the first violation and the signals there, and vacuity (docs/requirements.md,
Vacuity): what a requirement says of a run."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .robustness import Evaluator, Trace
from .syntax import Always, And, Eventually, Implies, Not, Or, Until, bounded_horizon, children, postorder, signals

PASS, FAIL, INCONCLUSIVE, ZERO = "PASS", "FAIL", "INCONCLUSIVE", "ZERO"


@dataclass(frozen=True)
class Verdict:
    """The verdict at the trace's start. robustness: the value when decided, else None (bounds: what is known).
    violation: the sample of the first violation (FAIL), its time and the formula's signals there.
    vacuous: a PASS or ZERO of `[always[a:b]] (p implies q)` whose antecedent p never held (robustness never > 0) at a
    judged sample: nothing was tested (see vacuity)."""

    verdict: str
    robustness: float | None
    bounds: tuple[float, float]
    violation_time: float | None
    violation_values: dict[str, float]
    decided_early: bool = False  # FAIL before the run covered the horizon: no continuation can make it pass
    vacuous: bool = False
    unknown: bool = False  # a NaN (a NaN sample, 0 / 0) where the formula reads: the verdict is what holds for any value

    @property
    def shown(self) -> str:
        """The verdict as tables and stored verdict columns show it: "PASS (vacuous)" for a vacuous pass."""
        return f"{self.verdict} (vacuous)" if self.vacuous else self.verdict


def verdict(formula, trace: Trace, final: bool = True, evaluator: Evaluator | None = None) -> Verdict:
    """PASS (robustness > 0), FAIL (< 0), ZERO (exactly 0: neither) when the trace covers the formula's horizon;
    before that, FAIL if no continuation of the trace can satisfy it, else INCONCLUSIVE (never a pass).

    A NaN robustness (a NaN sample or 0 / 0 where the formula reads) is a value not known, as a sample past the end:
    FAIL if no value could make it pass, PASS (its robustness the lower bound: the margin any value leaves) if none could
    make it fail, else INCONCLUSIVE: never a NaN verdict."""
    ev = evaluator or Evaluator(trace, final)
    if len(trace) == 0:
        return Verdict(INCONCLUSIVE, None, (-math.inf, math.inf), None, {})
    covered = final and trace.covers(bounded_horizon(formula))
    if covered:
        rho = ev.at_start(formula, "value")
        if rho < 0:
            j = first_violation(formula, ev, 0, "value")
            return Verdict(FAIL, rho, (rho, rho), float(trace.times[j]), _values(formula, trace, j))
        if rho >= 0:
            return Verdict(PASS if rho > 0 else ZERO, rho, (rho, rho), None, {}, vacuous=vacuity(formula, ev))
    low, high = ev.at_start(formula, "lower"), ev.at_start(formula, "upper")
    unknown = covered  # a NaN where the formula reads, not the run's end
    if high < 0:
        j = first_violation(formula, ev, 0, "upper")
        return Verdict(FAIL, None, (low, high), float(trace.times[j]), _values(formula, trace, j), decided_early=not unknown,
                       unknown=unknown)
    if unknown and low > 0:
        return Verdict(PASS, low, (low, high), None, {}, vacuous=vacuity(formula, ev), unknown=True)
    return Verdict(INCONCLUSIVE, None, (low, high), None, {}, unknown=unknown)


def decided_fail(formula, trace: Trace, evaluator: Evaluator | None = None) -> bool:
    """verdict(formula, trace, final=False) is FAIL: the robustness's upper bound over every continuation of the trace
    is below 0. Only that bound is computed (half of verdict's work): a check repeated while a run goes on."""
    ev = evaluator or Evaluator(trace, False)
    if ev.final:
        raise ValueError("decided_fail judges a trace still going on: its evaluator must not be final")
    if len(trace) == 0 or reads_from(formula, trace.period) >= len(trace):
        return False  # every sample it reads is still to come: unknown samples bound it above by +inf
    return ev.at_start(formula, "upper") < 0


class _Unbounded:
    """A trace's length and period as first_read sees them, for a trace longer than any window (no bound clamped)."""

    ticks = Trace.ticks

    def __init__(self, period: float) -> None:
        self.period = period

    def __len__(self) -> int:
        return 2**62


_READS_FROM: dict[tuple[int, float], tuple] = {}  # (id(formula), period) -> (formula, reads_from): the formula kept, so
# its id is not reused while it is here; no hash of the tree (a chain of thousands of `and`s is that deep)
_MOST_READS_FROM = 256


def reads_from(formula, period: float) -> int:
    """first_read on a trace of this period longer than any of the formula's windows, once per formula and period (a
    search's every check asks it). On a trace of n samples, first_read >= n exactly when this is: a bound past the
    trace's end is clamped to n + 1, and the sums and minimums of first_read keep ">= n" either way."""
    known = _READS_FROM.get((id(formula), period))
    if known is not None and known[0] is formula:
        return known[1]
    if len(_READS_FROM) >= _MOST_READS_FROM:
        _READS_FROM.clear()  # (one call: a Dask worker's threads share it)
    value = first_read(formula, _Unbounded(period))
    _READS_FROM[(id(formula), period)] = (formula, value)
    return value


def first_read(formula, trace: Trace) -> int:
    """The earliest sample the formula's robustness at the trace's start reads, in ticks as the evaluator's windows
    round their bounds (an until's left side counted from its start). A comparison reads its own sample."""
    done: dict[int, int] = {}
    for n in postorder(formula):
        kids = [done.pop(id(c)) for c in children(n)]
        if isinstance(n, (Always, Eventually)):
            done[id(n)] = trace.ticks(n.a) + kids[0]
        elif isinstance(n, Until):
            done[id(n)] = min(kids[0], trace.ticks(n.a) + kids[1])
        elif isinstance(n, (Not, And, Or, Implies)):
            done[id(n)] = min(kids)
        else:  # a comparison and the expressions in it: the sample itself
            done[id(n)] = 0
    return done[id(formula)]


def vacuity(formula, ev: Evaluator) -> bool:
    """Whether `always[a:b] (p implies q)` (or `p implies q`) at the trace's start is vacuous: p's robustness is a
    number <= 0 at every judged sample (the samples of [a, b] in the trace; the start alone without always). A NaN
    antecedent might have held: not vacuous. Any other top-level form: False."""
    node, lo, hi = formula, 0, 0
    if isinstance(node, Always):
        lo, hi = ev.trace.ticks(node.a), min(len(ev.trace) - 1, ev.trace.ticks_end(node.b))
        node = node.arg
    if not isinstance(node, Implies) or lo > hi:
        return False
    return bool(np.all(ev(node.left, "value")[lo:hi + 1] <= 0))


def first_violation(node, ev: Evaluator, i: int, mode: str) -> int:
    """The first sample where the formula, violated at sample i, is seen violated: through always (its first violating
    sample in the window) and and (the earliest of its violated sides); any other operator is violated at i. On an
    explicit stack: the answer is the earliest of the samples where the descent stops."""
    best, stack = None, [(node, i)]
    while stack:
        n, k = stack.pop()
        found = k
        if isinstance(n, Always):
            x = ev(n.arg, mode)
            lo, hi = k + ev.trace.ticks(n.a), min(len(x) - 1, k + ev.trace.ticks_end(n.b))
            bad = np.flatnonzero(x[lo:hi + 1] < 0) if lo <= hi else []
            if len(bad):
                stack.append((n.arg, lo + int(bad[0])))
                continue
        elif isinstance(n, And):
            sides = [(s, k) for s in (n.left, n.right) if ev(s, mode)[k] < 0]
            if sides:
                stack.extend(sides)
                continue
        best = found if best is None else min(best, found)
    return best


def _values(formula, trace: Trace, j: int) -> dict[str, float]:
    return {name: float(trace.signals[name][j]) for name in signals(formula) if name in trace.signals}

"""The STL monitor against its definition: a brute-force evaluator written here from the semantics (nested loops over
sample times), random formulas of depth >= 3 holding every operator on random traces, known answers by hand, the
windowed min/max against a naive slice, the bounds of an unfinished trace against the finished one, the parser."""

from __future__ import annotations

import math
import random

import numpy as np
import pytest
from tiltload.master.engine.stl import FAIL, INCONCLUSIVE, PASS, ZERO, Evaluator, StlError, Trace, parse, unparse, verdict
from tiltload.master.engine.stl import syntax as S
from tiltload.master.engine.stl.windows import sliding_min, sliding_min_deque

# --- the oracle: the definition, sample by sample ------------------------------------------------------------------


def _inside(t, t0, a, b, period):
    slack = 1e-9 * period
    return t0 + a - slack <= t <= t0 + b + slack


def brute_value(expr, trace, i):
    if isinstance(expr, S.Signal):
        return float(trace.signals[expr.name][i])
    if isinstance(expr, S.Const):
        return expr.value
    args = [brute_value(a, trace, i) for a in expr.args]
    if expr.op == "neg":
        return -args[0]
    if expr.op == "abs":
        return abs(args[0])
    l, r = args
    if expr.op == "/":
        return l / r if r != 0 else (math.copysign(math.inf, l) * math.copysign(1, r) if l != 0 else math.nan)
    return {"+": l + r, "-": l - r, "*": l * r}[expr.op]


def brute(f, trace, i):
    """rho(f, t_i) from the definition; samples past the end of the trace are absent (min of nothing = +inf)."""
    t, n, T = trace.times, len(trace), trace.period
    if isinstance(f, S.Compare):
        l, r = brute_value(f.left, trace, i), brute_value(f.right, trace, i)
        return {"<": r - l, "<=": r - l, ">": l - r, ">=": l - r, "==": -abs(l - r), "!==": abs(l - r)}[f.op]
    if isinstance(f, S.Not):
        return -brute(f.arg, trace, i)
    if isinstance(f, S.And):
        return min(brute(f.left, trace, i), brute(f.right, trace, i))
    if isinstance(f, S.Or):
        return max(brute(f.left, trace, i), brute(f.right, trace, i))
    if isinstance(f, S.Implies):
        return max(-brute(f.left, trace, i), brute(f.right, trace, i))
    window = [j for j in range(n) if _inside(t[j], t[i], f.a, f.b, T)]
    if isinstance(f, S.Always):
        return min([brute(f.arg, trace, j) for j in window], default=math.inf)
    if isinstance(f, S.Eventually):
        return max([brute(f.arg, trace, j) for j in window], default=-math.inf)
    best = -math.inf
    for j in window:  # until: q at t_j, p all the way from t_i up to (not including) t_j
        p_min = min([brute(f.left, trace, k) for k in range(i, j)], default=math.inf)
        best = max(best, min(brute(f.right, trace, j), p_min))
    return best


# --- random formulas ---------------------------------------------------------------------------------------------

NAMES = ("a.x", "a.y", "b.z")


def rand_expr(rng, depth):
    if depth == 0 or rng.random() < 0.3:
        return S.Signal(rng.choice(NAMES)) if rng.random() < 0.7 else S.Const(round(rng.uniform(-2, 2), 2))
    op = rng.choice(["+", "-", "*", "/", "neg", "abs"])
    if op in ("neg", "abs"):
        return S.Arith(op, (rand_expr(rng, depth - 1),))
    right = S.Const(rng.choice([2.0, -4.0, 0.5])) if op == "/" else rand_expr(rng, depth - 1)
    return S.Arith(op, (rand_expr(rng, depth - 1), right))


def rand_interval(rng, period):
    a = rng.randint(0, 4) * period
    b = a + rng.randint(0, 6) * period + (rng.choice([0, 0, 0.4]) * period)  # sometimes between ticks
    return a, b


def rand_formula(rng, depth, period):
    if depth == 0:
        return S.Compare(rng.choice(["<", "<=", ">", ">=", "==", "!=="]), rand_expr(rng, 2), rand_expr(rng, 1))
    kind = rng.choice(["not", "and", "or", "implies", "always", "eventually", "until", "until_inf", "always_inf"])
    sub = lambda: rand_formula(rng, depth - 1 if rng.random() < 0.8 else max(0, depth - 2), period)  # noqa: E731
    if kind == "not":
        return S.Not(sub())
    if kind in ("and", "or", "implies"):
        return {"and": S.And, "or": S.Or, "implies": S.Implies}[kind](sub(), sub())
    if kind == "always_inf":
        return S.Always(rng.randint(0, 2) * period, math.inf, sub())
    if kind == "until_inf":
        return S.Until(rng.randint(0, 2) * period, math.inf, sub(), sub())
    a, b = rand_interval(rng, period)
    if kind == "until":
        return S.Until(a, b, sub(), sub())
    return {"always": S.Always, "eventually": S.Eventually}[kind](a, b, sub())


def every_operator(rng, period):
    """A depth->=3 formula holding every operator once at least (and random subformulas below)."""
    r = lambda: rand_formula(rng, 1, period)  # noqa: E731
    a, b = rand_interval(rng, period)
    return S.Implies(S.Not(S.Always(a, b, S.Or(r(), S.Eventually(0, 3 * period, r())))),
                     S.And(S.Until(period, 4 * period, r(), r()), S.Always(0, math.inf, r())))


def rand_trace(rng, n, period):
    nrng = np.random.default_rng(rng.randint(0, 2**31))
    sig = {k: nrng.normal(size=n) for k in NAMES}
    sig["b.z"] = np.round(sig["b.z"], 0)  # ties: equal values, min and max without a unique place
    return Trace.uniform(np.arange(n) * period, sig, period)


def _same(got, want):
    both_nan = np.isnan(got) & np.isnan(want)
    close = np.isclose(got, want, rtol=0, atol=1e-12) | (got == want)
    return bool(np.all(both_nan | close))


@pytest.mark.parametrize("seed", range(40))
def test_random_formulas_equal_the_definition(seed):
    rng = random.Random(seed)
    period = rng.choice([1.0, 0.012, 0.25])
    trace = rand_trace(rng, rng.randint(1, 40), period)
    formulas = [every_operator(rng, period)] + [rand_formula(rng, 3, period) for _ in range(3)]
    for f in formulas:
        assert S.children(f)  # depth >= 3 by construction
        ev = Evaluator(trace)
        got = ev(f)
        want = np.array([brute(f, trace, i) for i in range(len(trace))])
        assert _same(got, want), (unparse(f), got, want)
        assert parse(unparse(f)) == f  # the text form reads back as the same tree


@pytest.mark.parametrize("seed", range(25))
def test_an_unfinished_trace_bounds_every_way_it_can_go_on(seed):
    """lower <= rho(full trace) <= upper at the start, for the prefix of a trace that covers the horizon."""
    rng = random.Random(1000 + seed)
    period = 0.5
    f = every_operator(rng, period)
    full = rand_trace(rng, 60, period)
    whole = Evaluator(full, final=True)(f)[0]
    for k in (1, 5, 17, 33):
        prefix = Trace.uniform(full.times[:k], {n: v[:k] for n, v in full.signals.items()}, period)
        ev = Evaluator(prefix, final=False)
        assert ev(f, "lower")[0] <= whole <= ev(f, "upper")[0]


# --- known answers, by hand ------------------------------------------------------------------------------------

X = [3.0, 2.0, 5.0, 0.5, 4.0]


def _trace(**sig):
    n = len(next(iter(sig.values())))
    return Trace.uniform(np.arange(n) * 1.0, {k.replace("_", "."): v for k, v in sig.items()}, 1.0)


def test_known_answers():
    tr = _trace(a_x=X, a_y=[0.0, 1.0, -1.0, 2.0, 0.0])
    ev = Evaluator(tr)
    # always[0:2] x > 1 at 0: min(3, 2, 5) - 1 = 1; at 1: min(2, 5, 0.5) - 1 = -0.5
    assert ev(parse("always[0:2] a.x > 1"))[:3].tolist() == [1.0, -0.5, -0.5]
    # eventually[1:2] x > 1 at 0: max(2, 5) - 1 = 4
    assert ev(parse("eventually[1:2] a.x > 1"))[0] == 4.0
    # (x > 1) until[1:3] (y > 1.5) at 0: t'=3 is the only time y > 1.5 (by 0.5); x over [0, 3) is 3, 2, 5: min - 1 = 1;
    # t'=1: min(1 - 1.5, x0 - 1 = 2) = -0.5; t'=2: min(-2.5, ...) -> max(-0.5, -2.5, min(0.5, 1)) = 0.5
    assert ev(parse("a.x > 1 until[1:3] a.y > 1.5"))[0] == 0.5
    # implies: max(-(x - 2), y - 0) at 0 = max(-1, 0) = 0
    assert ev(parse("a.x > 2 implies a.y > 0"))[0] == 0.0
    assert ev(parse("abs(a.x - 3) * 2 <= 1 / 2"))[0] == 0.5


def test_verdicts():
    tr = _trace(a_x=X)
    assert verdict(parse("always[0:4] a.x > 0"), tr).verdict == PASS
    v = verdict(parse("always[0:4] a.x > 1"), tr)
    assert (v.verdict, v.robustness, v.violation_time, v.violation_values) == (FAIL, -0.5, 3.0, {"a.x": 0.5})
    assert verdict(parse("always[0:4] a.x >= 0.5"), tr).verdict == ZERO  # robustness exactly 0 is neither
    assert verdict(parse("always[0:5] a.x > 0"), tr).verdict == INCONCLUSIVE  # the trace ends at 4 s
    early = verdict(parse("always[0:9] a.x > 1"), tr)  # violated at 3 s whatever comes after 4 s
    assert (early.verdict, early.decided_early, early.violation_time) == (FAIL, True, 3.0)
    # the first violation inside a conjunction is the earlier side's
    both = verdict(parse("always[0:4] a.x > 0.6 and always[0:4] a.x < 4.5"), tr)
    assert (both.verdict, both.violation_time) == (FAIL, 2.0)
    # a whole-run always on a finished trace is decided
    assert verdict(parse("always a.x > 0"), tr).verdict == PASS


# --- windows ---------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("seed", range(20))
def test_sliding_min_equals_a_slice_per_sample(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 80))
    x = np.round(rng.normal(size=n), 1)
    lo = int(rng.integers(0, 10))
    hi = lo + int(rng.integers(0, 30))
    pad = float(rng.choice([np.inf, -np.inf, 0.0]))
    naive = np.array([min([*x[i + lo:i + hi + 1], *([pad] if i + hi >= n else [])], default=pad) for i in range(n)])
    assert np.array_equal(sliding_min(x, lo, hi, pad), naive)
    assert np.array_equal(sliding_min_deque(x, lo, hi, pad), naive)


# --- the parser ------------------------------------------------------------------------------------------------

def test_precedence_and_aliases():
    assert parse("a.x > 1 or a.y > 1 and b.z > 1") == S.Or(parse("a.x > 1"), parse("a.y > 1 and b.z > 1"))
    assert parse("a.x > 1 -> a.y > 1 -> b.z > 1") == parse("a.x > 1 implies (a.y > 1 implies b.z > 1)")
    assert parse("G[0:1] !(a.x > 1) || F a.y > 0") == parse("always[0:1] (not a.x > 1) or eventually a.y > 0")
    assert parse("(a.x + 1) * 2 > 3") == S.Compare(">", S.Arith("*", (S.Arith("+", (S.Signal("a.x"), S.Const(1))), S.Const(2))),
                                                   S.Const(3))
    assert parse("a.x - -1 > 0").left == S.Arith("-", (S.Signal("a.x"), S.Const(-1.0)))
    assert parse("-(a.x) > 0").left == S.Arith("neg", (S.Signal("a.x"),))


@pytest.mark.parametrize("text, why, column", [
    ("always[2:1] a.x > 0", "reversed interval", 7),
    ("always[0:-1] a.x > 0", "negative time bound", 10),
    ("a.x > ", "expected a number", 7),
    ("x > 1", "is not instance.variable", 1),
    ("(a.x > 1", "expected ')'", 9),
    ("a.x $ 1", "unexpected character", 5),
    ("a.x + 1", "expected a comparison", 8),
    ("", "empty formula", None),
])
def test_parse_errors_are_one_line_with_the_place(text, why, column):
    with pytest.raises(StlError) as err:
        parse(text)
    msg = str(err.value)
    assert why in msg and "\n" not in msg
    if column is not None:
        assert f"column {column}:" in msg and "\u2192" in msg

"""The STL oracle of the monitor's tests: its definition evaluated sample by sample (nested loops over the sample
times, no windows, no deque), and random formulas (depth >= 3, every operator) and traces."""

from __future__ import annotations

import math

import numpy as np
from tiltload.master.engine.requirement.stl import Trace
from tiltload.master.engine.requirement.stl import syntax as S

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


def same(got, want):
    both_nan = np.isnan(got) & np.isnan(want)
    close = np.isclose(got, want, rtol=0, atol=1e-12) | (got == want)
    return bool(np.all(both_nan | close))

"""Issues 49 and 50 on the STL monitor: formulas of any size (evaluated or refused in one line naming the limit, never
Python's recursion limit), non-finite values (a NaN is a value not known: the verdict holds for every value it could
have had; checked against the brute-force definition on random fillings), huge intervals, and vacuity (against a
brute-force definition: the antecedent's robustness never positive at a judged sample)."""

from __future__ import annotations

import math
import random
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from support.stl_oracle import brute, rand_formula, rand_trace
from tiltload.master.engine.requirement.stl import (
    FAIL,
    INCONCLUSIVE,
    PASS,
    ZERO,
    Evaluator,
    StlError,
    Trace,
    horizon,
    parse,
    signals,
    unparse,
    verdict,
)
from tiltload.master.engine.requirement.stl import syntax as S

TRACE = Trace.uniform(np.arange(50) * 0.1, {"a.x": np.linspace(1.0, 2.0, 50), "a.y": np.linspace(-1.0, 1.0, 50)}, 0.1)


def _deep_stack(depth: int, call):
    """call() from `depth` frames down: the monitor must not lean on the room the caller left."""
    return call() if depth == 0 else _deep_stack(depth - 1, call)


# --- formulas of any size ----------------------------------------------------------------------------------------

@pytest.mark.parametrize("text, robustness", [
    (" and ".join(["a.x > 0.5"] * 2000), 0.5),                 # a left-deep chain 2000 long
    (" or ".join(["a.x > 0.5"] * 2000), 0.5),                  # x(0) = 1: every side 0.5
    (" -> ".join(["a.x > 0.5"] * 2000), 0.5),                  # right-associative
    ("a.x" + " + a.x" * 3000 + " > 0", 3001.0),                # an expression chain
    ("(" * 50 + "a.x > 0.5" + ")" * 50, 0.5),                  # the nesting limit itself
    ("always[0:0.1] " * 20 + "eventually " + "not " * 29 + "a.x > 0.5", None),
])
def test_long_chains_and_the_deepest_nesting_are_evaluated(text, robustness):
    def judge():
        f = parse(text)
        unparse(f), signals(f), horizon(f)
        return verdict(f, TRACE)
    v = _deep_stack(sys.getrecursionlimit() // 2, judge)  # half the stack already used by the caller
    assert v.verdict in (PASS, FAIL, ZERO, INCONCLUSIVE)
    if robustness is not None:
        assert v.robustness == robustness
    if " and " in text or " or " in text:  # a chain's text (--explain) reads back
        f = parse(text)
        assert unparse(parse(unparse(f))) == unparse(f)


@pytest.mark.parametrize("text, limit", [
    ("(" * 51 + "a.x > 0" + ")" * 51, "nested deeper than 50 levels"),
    ("(" * 5000 + "a.x > 0" + ")" * 5000, "nested deeper than 50 levels"),
    ("not " * 5000 + "a.x > 0", "nested deeper than 50 levels"),
    ("-" * 5000 + "a.x > 0", "nested deeper than 50 levels"),
    ("abs(" * 5000 + "a.x" + ")" * 5000 + " > 0", "nested deeper than 50 levels"),
    ("always[0:1] " * 5000 + "a.x > 0", "nested deeper than 50 levels"),
    ("a.x > 0 and " * 100000 + "a.x > 0", "at most 65536"),
    (" and ".join(["a.x>0"] * 3000), "at most 10000"),  # 12,000 nodes in 20 KB
    ("a.x > 1e999", "beyond a double's range"),
    ("always[0:1e999] a.x > 0", "beyond a double's range"),
    ("a.x > -1e400", "beyond a double's range"),
])
def test_beyond_a_limit_is_one_line_naming_it(text, limit):
    with pytest.raises(StlError) as err:
        _deep_stack(sys.getrecursionlimit() // 2, lambda: parse(text))
    msg = str(err.value)
    assert limit in msg and "\n" not in msg and len(msg) < 400  # the formula is cut around the place, not echoed whole


@settings(max_examples=60, deadline=None)
@given(st.lists(st.sampled_from(["a.x > 0", "(", ")", " and ", " or ", " -> ", "not ", "always[0:1] ", "eventually ",
                                 "-", "abs(", "a.y", " + ", " until ", "1e999", "0 / 0"]), max_size=400))
def test_any_token_soup_parses_or_is_one_stl_error(parts):
    """Whatever the text, parse returns a tree or raises StlError with one line: never RecursionError."""
    text = "".join(parts)
    try:
        f = parse(text)
    except StlError as err:
        assert "\n" not in str(err)
        return
    try:
        verdict(f, TRACE)
    except StlError as err:  # an expression where a formula goes
        assert "\n" not in str(err)


# --- non-finite values ---------------------------------------------------------------------------------------------

def test_division_by_zero_is_ieee_and_never_a_nan_zero():
    assert verdict(parse("a.x / 0 > 1"), TRACE).robustness == math.inf  # x > 0: +inf
    v = verdict(parse("0 / 0 < a.x"), TRACE)  # NaN everywhere: nothing known
    assert v.verdict == INCONCLUSIVE and v.unknown and v.robustness is None


def _fill(trace: Trace, rng: np.random.Generator) -> Trace:
    return Trace.uniform(trace.times, {k: np.where(np.isnan(v), rng.normal(scale=3, size=len(v)), v)
                                       for k, v in trace.signals.items()}, trace.period)


@pytest.mark.parametrize("seed", range(30))
def test_a_nan_sample_is_a_value_not_known_against_the_definition(seed):
    """With NaN samples, every filling of them (the brute-force definition on the filled trace) lies within the
    bounds; PASS means every filling passes, FAIL every filling fails; never a NaN robustness."""
    rng = random.Random(seed)
    period = 0.5
    trace = rand_trace(rng, 30, period)
    nrng = np.random.default_rng(seed)
    for k in trace.signals:
        trace.signals[k][nrng.random(30) < 0.1] = np.nan
    f = rand_formula(rng, 3, period)
    v = verdict(f, trace, final=True)
    assert v.robustness is None or not math.isnan(v.robustness)
    for _ in range(8):
        rho = brute(f, _fill(trace, nrng), 0)
        assert v.bounds[0] - 1e-12 <= rho <= v.bounds[1] + 1e-12, (unparse(f), v, rho)
        if v.verdict == PASS:
            assert rho > 0
        if v.verdict == FAIL:
            assert rho < 0


def test_a_nan_signal_is_decided_where_it_can_be():
    y = np.r_[np.ones(25), np.full(25, np.nan)]
    tr = Trace.uniform(TRACE.times, {"a.y": y}, 0.1)
    assert verdict(parse("always[0:2] a.y > 0"), tr).verdict == PASS  # the window ends before the NaN
    nan_window = verdict(parse("always[0:4.9] a.y > 0"), tr)
    assert (nan_window.verdict, nan_window.unknown) == (INCONCLUSIVE, True)
    failed = verdict(parse("always[0:4.9] a.y > 5"), tr)  # violated before the NaN, whatever it is
    assert (failed.verdict, failed.violation_time, failed.decided_early) == (FAIL, 0.0, False)
    held = verdict(parse("eventually[0:4.9] a.y > 0.5"), tr)  # held before the NaN: its margin is a lower bound
    assert (held.verdict, held.robustness) == (PASS, 0.5)


@pytest.mark.parametrize("text", ["always[0:1e308] a.x > 0", "eventually[1e300:1e308] a.x > 0", "a.x > 0 until[0:1e308] a.y > 0",
                                  "a.x > 0 until[1e300:inf] a.y > 0", "always[1e300:inf] a.x > 0"])
def test_a_huge_interval_is_no_overflow_and_no_allocation(text):
    f = parse(text)
    v = verdict(f, TRACE)
    assert v.verdict == INCONCLUSIVE or text.endswith(("inf] a.x > 0", "inf] a.y > 0"))
    Evaluator(TRACE, final=False)(f, "upper")  # the online monitor's bound: no OverflowError


# --- vacuity, against its brute-force definition ----------------------------------------------------------------------

def _brute_vacuous(f, trace) -> bool:
    """always[a:b] (p implies q) at t0: every sample of the window has rho(p) <= 0 (by the definition)."""
    body, window = f, [0]
    if isinstance(f, S.Always):
        body = f.arg
        window = [j for j in range(len(trace)) if f.a - 1e-9 * trace.period <= trace.times[j] <= f.b + 1e-9 * trace.period]
    return isinstance(body, S.Implies) and bool(window) and all(brute(body.left, trace, j) <= 0 for j in window)


@pytest.mark.parametrize("seed", range(60))
def test_vacuity_equals_its_definition(seed):
    rng = random.Random(5000 + seed)
    period = 0.25
    trace = rand_trace(rng, 40, period)
    p, q = rand_formula(rng, rng.randint(0, 2), period), rand_formula(rng, rng.randint(0, 2), period)
    if rng.random() < 0.5:  # an antecedent that rarely holds: vacuity is common, not only possible
        p = S.And(p, S.Compare(">", S.Signal("a.x"), S.Const(rng.choice([1.5, 2.5, 9.0]))))
    a = rng.randint(0, 3) * period
    f = rng.choice([S.Always(a, a + rng.randint(0, 8) * period, S.Implies(p, q)), S.Implies(p, q)])
    if horizon(f) > trace.times[-1]:
        return
    v = verdict(f, trace)
    expected = _brute_vacuous(f, trace) and v.verdict in (PASS, ZERO)
    assert v.vacuous == expected, (unparse(f), v)
    if _brute_vacuous(f, trace):  # the definition's consequence: a vacuous formula cannot fail
        assert v.verdict in (PASS, ZERO)


def test_vacuity_only_of_implies_at_the_top():
    tr = Trace.uniform(TRACE.times, {"a.x": TRACE.signals["a.x"]}, 0.1)
    assert verdict(parse("always[0:4] (a.x > 5 implies a.x < 0)"), tr).vacuous  # x never above 5
    assert not verdict(parse("always[0:4] (a.x > 1.5 implies a.x > 0)"), tr).vacuous  # held from 2.6 s
    assert not verdict(parse("always[0:4] (not a.x > 5 or a.x < 0)"), tr).vacuous  # the same, not written as implies
    assert verdict(parse("always[0:4] (a.x > 5 implies a.x < 0)"), tr).shown == "PASS (vacuous)"


# --- a long bounded until: O(n), the same values as the window's passes and as the definition -------------------------

@pytest.mark.parametrize("seed", range(40))
def test_a_long_until_window_equals_the_passes_and_the_definition(seed, monkeypatch):
    from tiltload.master.engine.requirement.stl import robustness as R

    rng = random.Random(9000 + seed)
    period = rng.choice([1.0, 0.25])
    trace = rand_trace(rng, rng.randint(1, 40), period)
    a = rng.randint(0, 5) * period
    f = S.Until(a, a + rng.randint(0, 45) * period + rng.choice([0, 0.4]) * period, rand_formula(rng, 1, period),
                rand_formula(rng, 1, period))
    f = S.Not(S.Always(0, 3 * period, f)) if rng.random() < 0.3 else f
    for final in (True, False):
        for mode in ("value", "lower", "upper"):
            monkeypatch.setattr(R, "UNTIL_PASSES", 10**9)  # every window by its passes
            passes = Evaluator(trace, final)(f, mode)
            monkeypatch.setattr(R, "UNTIL_PASSES", -1)  # every window by _until_long
            assert np.array_equal(Evaluator(trace, final)(f, mode), passes), (unparse(f), final, mode)
    want = np.array([brute(f, trace, i) for i in range(len(trace))])
    assert np.array_equal(Evaluator(trace)(f), want), unparse(f)

"""The STL monitor against its definition: a brute-force evaluator (support/stl_oracle.py: nested loops over
sample times), random formulas of depth >= 3 holding every operator on random traces, known answers by hand, the
windowed min/max against a naive slice, the bounds of an unfinished trace against the finished one, the parser."""

from __future__ import annotations

import random

import numpy as np
import pytest
from support.stl_oracle import brute, every_operator, rand_formula, rand_trace, same
from tiltload.master.engine.requirement.stl import (
    FAIL,
    INCONCLUSIVE,
    PASS,
    ZERO,
    Evaluator,
    StlError,
    Trace,
    decided_fail,
    parse,
    reads_from,
    unparse,
    verdict,
)
from tiltload.master.engine.requirement.stl import syntax as S
from tiltload.master.engine.requirement.stl.verdicts import first_read
from tiltload.master.engine.requirement.stl.windows import sliding_min, sliding_min_deque


@pytest.mark.parametrize("seed", range(40))
@pytest.mark.slow
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
        assert same(got, want), (unparse(f), got, want)
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


@pytest.mark.parametrize("seed", range(25))
def test_a_decided_fail_is_a_fail_of_every_way_the_trace_goes_on(seed):
    """decided_fail on a prefix (the early-stop check) is verdict's FAIL there, and then every whole trace that begins
    with the prefix fails by the brute-force definition; an always whose prefix already holds a violation is decided."""
    rng = random.Random(2000 + seed)
    period = 0.5
    formulas = [every_operator(rng, period), rand_formula(rng, 3, period), parse("always[1:20] a.x > 0"),
                parse("always[9:12] (a.y > 0 until[1:2] a.x < 0)")]  # reads nothing before 9 s (sample 18)
    for f in formulas:
        for _ in range(3):
            full = rand_trace(rng, 50, period)
            for k in (1, 6, 19, 37):
                prefix = Trace.uniform(full.times[:k], {n: v[:k] for n, v in full.signals.items()}, period)
                decided = decided_fail(f, prefix)
                assert decided == (verdict(f, prefix, final=False).verdict == FAIL)
                if decided:
                    assert brute(f, full, 0) < 0, unparse(f)
                if unparse(f).startswith("always[9:12]") and k <= 18:
                    assert not decided  # nothing it reads has come yet
                if unparse(f) == "always[1:20] a.x > 0" and k > 2:
                    assert decided == bool(np.any(full.signals["a.x"][2:k] < 0))  # samples 2.. are in the window
    with pytest.raises(ValueError, match="must not be final"):
        decided_fail(formulas[0], full, Evaluator(full, final=True))


@pytest.mark.parametrize("seed", range(20))
def test_the_robustness_at_the_start_alone_is_the_signal_s_first_sample(seed):
    """Evaluator.at_start (a verdict's and the early-stop check's question) against the whole signal's first sample in
    every mode, finished and not, with windows inside, across and past the trace's end, on samples with NaN and inf;
    and against the brute-force definition (on the samples without them: the oracle's arithmetic is Python's)."""
    rng = random.Random(4000 + seed)
    period = rng.choice([1.0, 0.25])
    for _ in range(6):
        clean = rand_trace(rng, rng.randint(1, 30), period)
        trace = Trace.uniform(clean.times, {n: v.copy() for n, v in clean.signals.items()}, period)
        x = trace.signals["a.x"]
        x[rng.randrange(len(x))] = rng.choice([np.nan, np.inf, -np.inf, 0.0])
        inner = unparse(rand_formula(rng, 2, period))
        a = rng.choice([0, 1, 3, 12, 40]) * period
        b = a + rng.choice([0, 2, 9, 60]) * period
        texts = [f"always[{a}:{b}] ({inner})", f"eventually[{a}:{b}] ({inner})", f"always ({inner})", inner]
        for text in texts:
            f = parse(text)
            for final in (True, False):
                for mode in ("value", "lower", "upper"):
                    want = Evaluator(trace, final)(f, mode)[0]
                    got = Evaluator(trace, final).at_start(f, mode)
                    assert same(np.array([got]), np.array([want])), (text, final, mode, got, want)
            assert same(np.array([Evaluator(clean).at_start(f)]), np.array([brute(f, clean, 0)])), text


@pytest.mark.parametrize("seed", range(20))
def test_reads_from_says_what_first_read_says_of_every_trace_length(seed):
    """reads_from (once per formula and period, for the early-stop check) >= n exactly when first_read on a trace of n
    samples is, for random formulas and windows that end before, inside and past the traces."""
    rng = random.Random(3000 + seed)
    period = rng.choice([1.0, 0.012, 0.25])
    formulas = [every_operator(rng, period), rand_formula(rng, 3, period), parse(f"always[{200 * period}:{300 * period}] a.x > 0"),
                parse(f"a.x > 0 until[{30 * period}:{90 * period}] (eventually[{7 * period}:{9 * period}] a.y > 0)")]
    for f in formulas:
        for n in range(1, 80):
            trace = rand_trace(rng, n, period)
            assert (reads_from(f, period) >= n) == (first_read(f, trace) >= n), (unparse(f), n)
        assert reads_from(f, period) == reads_from(f, period)  # the second from its cache


def test_an_until_whose_window_lies_past_the_trace_is_not_decided():
    """p until[3:6] q on one sample: every t' of the window is still to come, so a continuation with q large there
    satisfies it (the upper bound is p's, here +inf); on the finished trace no t' exists (-inf, rtamt's value)."""
    f = parse("a.x > 0 until[1.5:3] a.y > 0")
    one = Trace.uniform([0.0], {"a.x": np.array([1.0]), "a.y": np.array([-1.0])}, 0.5)
    going_on = Evaluator(one, final=False)
    assert going_on(f, "upper")[0] == 1.0 and going_on(f, "lower")[0] == -np.inf  # p's margin bounds it above
    assert verdict(f, one, final=False).verdict == INCONCLUSIVE and not decided_fail(f, one)
    assert Evaluator(one, final=True)(f)[0] == -np.inf


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


def test_the_worked_example_of_the_docs():
    """docs/requirements.md, "A worked example": the margins by hand."""
    tr = Trace.uniform(np.arange(6) * 0.5, {"plant.x": [0.30, 0.25, 0.12, 0.05, 0.08, 0.02], "scenario.x_ref": [0.0] * 6}, 0.5)
    e = "abs(plant.x - scenario.x_ref)"
    v = verdict(parse(f"always[1:2] {e} < 0.2"), tr)
    assert v.verdict == PASS and v.robustness == pytest.approx(0.08, abs=1e-15)
    v = verdict(parse(f"always[0.5:2] {e} < 0.2"), tr)
    assert (v.verdict, v.violation_time, v.violation_values["plant.x"]) == (FAIL, 0.5, 0.25)
    v = verdict(parse(f"always[1:3] {e} < 0.2"), tr)
    assert v.verdict == INCONCLUSIVE and v.bounds[1] == pytest.approx(0.08, abs=1e-15) and v.bounds[0] == -np.inf
    v = verdict(parse(f"always[0:3] {e} < 0.2"), tr)
    assert v.verdict == FAIL and v.decided_early and v.bounds[1] == pytest.approx(-0.1, abs=1e-15)
    assert verdict(parse(f"always[1:2] {e} <= 0.12"), tr).verdict == ZERO

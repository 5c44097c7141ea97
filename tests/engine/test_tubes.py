"""Tolerance tubes (engine/tubes.py) against a brute-force reading of their definition (docs/back_to_back.md), written
here without the engine's windows: for each check point, every reference sample whose hold interval meets the window."""

from __future__ import annotations

import math

import numpy as np
import pytest
from tiltload.master.engine.tubes import Tolerance, tube


def brute_force(t_ref, y_ref, t, y, tol: Tolerance):
    """(points, outside, excess) by the definition, one point and one reference sample at a time."""
    t_ref, y_ref, t, y = (list(map(float, a)) for a in (t_ref, y_ref, t, y))
    t0, t1 = t_ref[0], t_ref[-1]
    candidates = [t0, t1, *t, *(s - tol.lead for s in t_ref), *(s + tol.lag for s in t_ref)]
    points = sorted({p for p in candidates if t0 <= p <= t1})
    outside, excess = [], []
    for p in points:
        lo, hi, held = math.inf, -math.inf, []
        for k, s in enumerate(t_ref):
            begins = -math.inf if k == 0 else s  # the first sample also holds before the reference starts
            ends = t_ref[k + 1] if k + 1 < len(t_ref) else math.inf  # [begins, ends): empty for a repeated time
            if begins <= p + tol.lead and ends > p - tol.lag and ends > s:
                held.append(y_ref[k])
                if math.isfinite(y_ref[k]):
                    w = max(tol.absolute, tol.relative * abs(y_ref[k]))
                    lo, hi = min(lo, y_ref[k] - w), max(hi, y_ref[k] + w)
        mine = [v for s, v in zip(t, y) if s <= p]
        if not mine or p > t[-1]:
            outside.append(True)
            excess.append(math.inf)
            continue
        c = mine[-1]
        if math.isnan(c):
            ok = any(math.isnan(v) for v in held)
            e = 0.0 if ok else math.inf
        elif math.isinf(c):
            ok = c in held
            e = 0.0 if ok else math.inf
        else:
            e = max(lo - c, c - hi, 0.0)
        outside.append(e > 0)
        excess.append(e)
    return np.array(points), np.array(outside), np.array(excess)


def _grid(rng, n, t_end=2.0):
    if n == 1:
        return np.array([rng.uniform(0, t_end)])
    return np.sort(np.concatenate([[0.0, t_end], rng.uniform(0, t_end, n - 2)]))


def _signal(rng, t):
    a, f, phase = rng.uniform(0.5, 3, 3), rng.uniform(0.5, 4, 3), rng.uniform(0, 6, 3)
    return (a[:, None] * np.sin(f[:, None] * t[None, :] + phase[:, None])).sum(axis=0)


def _case(rng):
    """A reference and a candidate: shifted, rescaled, spiked, on another grid, with NaN / inf, shorter."""
    t_ref = _grid(rng, int(rng.integers(2, 60)))
    if rng.random() < 0.2:  # whole repeated times, as a log can hold them
        t_ref = np.sort(np.concatenate([t_ref, t_ref[rng.integers(0, len(t_ref), 3)]]))
    y_ref = _signal(rng, t_ref)
    t = t_ref.copy() if rng.random() < 0.4 else _grid(rng, int(rng.integers(1, 60)))
    shift = rng.choice([0.0, rng.uniform(-0.2, 0.2)])
    y = np.interp(t - shift, t_ref, y_ref) * rng.choice([1.0, rng.uniform(0.9, 1.1)]) + rng.choice([0.0, rng.uniform(-0.1, 0.1)])
    if rng.random() < 0.4:
        y[rng.integers(0, len(y))] += rng.uniform(-5, 5)  # a spike
    for arr in (y_ref, y):
        if rng.random() < 0.3:
            k = rng.integers(0, len(arr))
            arr[k:k + int(rng.integers(1, 4))] = rng.choice([np.nan, np.inf, -np.inf])
    if rng.random() < 0.15:
        t, y = t[: max(1, len(t) // 2)], y[: max(1, len(t) // 2)]  # a run that ended early
    if rng.random() < 0.1:
        t = t + 0.3  # one that starts late
    tol = Tolerance(*(rng.choice([0.0, rng.uniform(0, x)]) for x in (0.3, 0.1, 0.15, 0.15)))
    return t_ref, y_ref, t, y, tol


@pytest.mark.parametrize("seed", range(400))
def test_tube_equals_the_brute_force_definition(seed):
    rng = np.random.default_rng(seed)
    t_ref, y_ref, t, y, tol = _case(rng)
    result = tube(t_ref, y_ref, t, y, tol)
    points, outside, excess = brute_force(t_ref, y_ref, t, y, tol)
    np.testing.assert_array_equal(result.time, points)
    np.testing.assert_array_equal(result.outside, outside)
    np.testing.assert_array_equal(result.excess, excess)
    assert result.passed == (not outside.any())
    first = points[outside][0] if outside.any() else None
    assert result.first_outside == first
    if outside.any():
        k = int(np.argmax(excess))
        assert result.largest_excess == (excess[k], points[k])
        span = points[-1] - points[0]
        share = sum(b - a for a, b, o in zip(points, points[1:], outside) if o) / span if len(points) > 1 else 1.0
        assert result.share_outside == pytest.approx(share, abs=1e-12)


def test_a_late_step_passes_with_enough_lag_and_fails_by_what_is_missing():
    t = np.round(np.arange(0, 2.0001, 0.01), 10)
    ref, late = (t >= 1.0).astype(float), (t >= 1.1).astype(float)
    assert tube(t, ref, t, late, Tolerance(lag=0.1)).passed
    assert not tube(t, ref, t, late, Tolerance(lead=0.1)).passed  # early is not late
    short = tube(t, ref, t, late, Tolerance(lag=0.05))
    assert short.first_outside == pytest.approx(1.05)
    assert short.share_outside == pytest.approx(0.05 / 2.0)
    assert short.largest_excess[0] == 1.0


def test_absolute_and_relative_widths_and_nan_equal_nan():
    t = np.linspace(0, 1, 11)
    ref = np.full(11, 10.0)
    assert tube(t, ref, t, ref + 0.5, Tolerance(absolute=0.5)).passed
    assert not tube(t, ref, t, ref + 0.51, Tolerance(absolute=0.5)).passed
    assert tube(t, ref, t, ref * 1.05, Tolerance(absolute=0.1, relative=0.05)).passed  # max(a, r|ref|) = 0.5
    ref[3] = np.nan
    cand = ref.copy()
    assert tube(t, ref, t, cand, Tolerance()).passed
    cand[7] = np.nan  # a diverging candidate: out from its first NaN, never a crash
    diverged = tube(t, ref, t, cand, Tolerance(absolute=1.0))
    assert diverged.first_outside == pytest.approx(0.7) and diverged.largest_excess == (math.inf, pytest.approx(0.7))


def test_a_candidate_on_another_grid_is_held_not_interpolated():
    t_ref = np.array([0.0, 1.0, 2.0])
    ref = np.array([0.0, 1.0, 2.0])
    t = np.array([0.0, 0.5, 1.0, 1.5, 2.0])
    assert tube(t_ref, ref, t, np.array([0.0, 0.0, 1.0, 1.0, 2.0]), Tolerance()).passed
    off = tube(t_ref, ref, t, np.array([0.0, 0.5, 1.0, 1.0, 2.0]), Tolerance())  # 0.5 at t = 0.5 where the reference holds 0
    assert off.first_outside == 0.5 and off.share_outside == pytest.approx(0.25)


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"absolute": -1.0}, "tolerance absolute = -1.0 must be a finite number >= 0"),
    ({"lag": math.inf}, "tolerance lag = inf must be a finite number >= 0"),
    ({"relative": math.nan}, "tolerance relative = nan must be a finite number >= 0"),
])
def test_bad_tolerances_are_one_line(kwargs, message):
    with pytest.raises(ValueError, match=f"^{message}$".replace("(", r"\(")):
        Tolerance(**kwargs)


@pytest.mark.parametrize(("t", "y", "message"), [
    ([0.0, 1.0], [1.0], "x: 2 times but 1 values (signals of different lengths)"),
    ([0.0, 2.0, 1.0], [1.0, 1.0, 1.0], "x: times go back (t = 2 s then 1 s at sample 2)"),
    ([0.0, np.nan], [1.0, 1.0], "x: a time is not finite (at sample 1)"),
    ([], [], "x: no samples"),
])
def test_bad_signals_are_one_line(t, y, message):
    with pytest.raises(ValueError) as err:
        tube([0.0, 1.0], [0.0, 0.0], t, y, Tolerance(), what="x")
    assert str(err.value) == message

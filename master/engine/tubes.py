"""Tolerance tubes: a candidate signal against a reference, Simulink Test's criteria (docs/back_to_back.md).

Per signal an absolute tolerance a, a relative r, a leading l and a lagging g (s). Both signals are zero-order held on
their own grids. At a time t the reference's window is [t - g, t + l]; the band is the hull of [y - tol(y), y + tol(y)]
over the reference's finite values y held in that window, tol(y) = max(a, r |y|). A finite candidate value passes if
it lies in the band; a NaN or infinite one if the window holds the very same non-finite value (NaN equals NaN). The
check points are every time where the candidate or the band can change, so the verdict is exact between them.
Sliding minima and maxima over the windows come from a sparse table: O(n log n), no Python loop over samples.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Tolerance:
    """A signal's tolerances: absolute (its unit), relative (of |reference|), lead and lag (s: the candidate may be early
    by up to lead, late by up to lag)."""

    absolute: float = 0.0
    relative: float = 0.0
    lead: float = 0.0
    lag: float = 0.0

    def __post_init__(self) -> None:
        for name in ("absolute", "relative", "lead", "lag"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0:
                raise ValueError(f"tolerance {name} = {value!r} must be a finite number >= 0")

    def words(self) -> str:
        return f"abs {self.absolute:g}, rel {self.relative:g}, lead {self.lead:g} s, lag {self.lag:g} s"


@dataclass(frozen=True, eq=False)
class Tube:
    """A candidate inside its tube, point by point (the check points), and the verdict's summary.

    outside: the check points where the candidate leaves the band (or is NaN/inf without the same in the window, or
    is missing: past its last sample or before its first). excess: how far outside (inf for a non-finite or missing
    value), 0 inside."""

    time: np.ndarray
    value: np.ndarray  # the candidate, held (NaN where it is missing)
    lower: np.ndarray  # the band (inf / -inf where the window holds no finite reference value)
    upper: np.ndarray
    outside: np.ndarray
    excess: np.ndarray
    missing: np.ndarray  # the candidate has no sample yet or any more

    @property
    def passed(self) -> bool:
        return not self.outside.any()

    @property
    def first_outside(self) -> float | None:
        """The first time the candidate is outside (s), None if never."""
        k = np.flatnonzero(self.outside)
        return float(self.time[k[0]]) if len(k) else None

    @property
    def largest_excess(self) -> tuple[float, float] | None:
        """(the largest excess, its time), None if never outside; inf for a non-finite or missing candidate."""
        if not self.outside.any():
            return None
        k = int(np.argmax(self.excess))
        return float(self.excess[k]), float(self.time[k])

    @property
    def share_outside(self) -> float:
        """The share of the compared time the candidate is outside: each check point holds to the next one; a single
        point counts whole."""
        if len(self.time) == 1:
            return float(self.outside[0])
        span = self.time[-1] - self.time[0]
        held = np.diff(self.time)
        return float(held[self.outside[:-1]].sum() / span)


def check_signal(times, values, what: str) -> tuple[np.ndarray, np.ndarray]:
    """A signal's times and values as float arrays: the same length, at least one sample, times finite and in order."""
    t, y = np.asarray(times, dtype=float), np.asarray(values, dtype=float)
    if t.ndim != 1 or y.ndim != 1:
        raise ValueError(f"{what}: times and values must be one-dimensional")
    if len(t) != len(y):
        raise ValueError(f"{what}: {len(t)} times but {len(y)} values (signals of different lengths)")
    if len(t) == 0:
        raise ValueError(f"{what}: no samples")
    if not np.isfinite(t).all():
        raise ValueError(f"{what}: a time is not finite (at sample {int(np.flatnonzero(~np.isfinite(t))[0])})")
    back = np.flatnonzero(np.diff(t) < 0)
    if len(back):
        k = int(back[0])
        raise ValueError(f"{what}: times go back (t = {t[k]:g} s then {t[k + 1]:g} s at sample {k + 1})")
    return t, y


def _window_reduce(x: np.ndarray, start: np.ndarray, stop: np.ndarray, op) -> np.ndarray:
    """op (np.minimum or np.maximum) over x[start[i]:stop[i] + 1] for every i (start <= stop): a sparse table."""
    levels = [x]
    while 2 ** len(levels) <= len(x):
        prev, half = levels[-1], 2 ** (len(levels) - 1)
        levels.append(op(prev[:-half], prev[half:]))
    length = stop - start + 1
    level = np.floor(np.log2(length)).astype(int)
    level -= (1 << level) > length  # guard against log2 rounding up at exact powers of two
    out = np.empty(len(start))
    for k in np.unique(level):
        sel = level == k
        table = levels[k]
        out[sel] = op(table[start[sel]], table[stop[sel] - (1 << k) + 1])
    return out


def _count_in_windows(flags: np.ndarray, start: np.ndarray, stop: np.ndarray) -> np.ndarray:
    cumulative = np.concatenate([[0], np.cumsum(flags)])
    return cumulative[stop + 1] - cumulative[start]


def _held(t: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The samples a zero-order hold keeps: of several at one time, the last."""
    keep = np.append(np.diff(t) > 0, True)
    return t[keep], y[keep]


def check_points(t_ref: np.ndarray, t: np.ndarray, tol: Tolerance) -> np.ndarray:
    """Where the verdict can change, over the reference's span: the candidate's samples, each reference sample as
    the window's far end (t - lead) and near end (t + lag) meet it, and the span's ends."""
    t0, t1 = t_ref[0], t_ref[-1]
    points = np.concatenate([[t0, t1], t, t_ref - tol.lead, t_ref + tol.lag])
    points = points[(points >= t0) & (points <= t1)]
    return np.unique(points)


def tube(t_ref, y_ref, t, y, tol: Tolerance, what: str = "signal") -> Tube:
    """The candidate (t, y) inside the tube of the reference (t_ref, y_ref) over the reference's span."""
    t_ref, y_ref = check_signal(t_ref, y_ref, f"{what} (reference)")
    t, y = check_signal(t, y, what)
    t_ref, y_ref = _held(t_ref, y_ref)
    t, y = _held(t, y)
    points = check_points(t_ref, t, tol)
    # the reference's samples held somewhere in [p - lag, p + lead]: from the last at or before p - lag (or the first)
    # to the last at or before p + lead
    first = np.maximum(np.searchsorted(t_ref, points - tol.lag, side="right") - 1, 0)
    last = np.maximum(np.searchsorted(t_ref, points + tol.lead, side="right") - 1, 0)
    finite = np.isfinite(y_ref)
    width = np.maximum(tol.absolute, tol.relative * np.abs(np.where(finite, y_ref, 0.0)))
    lower = _window_reduce(np.where(finite, y_ref - width, np.inf), first, last, np.minimum)
    upper = _window_reduce(np.where(finite, y_ref + width, -np.inf), first, last, np.maximum)
    # the candidate held on its own grid, missing before its first sample and after its last
    k = np.searchsorted(t, points, side="right") - 1
    missing = (k < 0) | (points > t[-1])
    value = np.where(missing, np.nan, y[np.maximum(k, 0)])
    with np.errstate(invalid="ignore"):  # inf - inf: a non-finite candidate, judged below
        excess = np.maximum(np.maximum(lower - value, value - upper), 0.0)
    nonfinite_ok = np.zeros(len(points), dtype=bool)
    for same, flags in ((np.isnan(value), np.isnan(y_ref)), (value == np.inf, y_ref == np.inf), (value == -np.inf, y_ref == -np.inf)):
        nonfinite_ok |= same & (_count_in_windows(flags, first, last) > 0)
    bad_value = ~np.isfinite(value)
    excess = np.where(bad_value | np.isnan(excess), np.where(nonfinite_ok & ~missing, 0.0, np.inf), excess)
    outside = (excess > 0) | missing
    return Tube(points, value, lower, upper, outside, excess, missing)

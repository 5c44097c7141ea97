"""Signals decimated for a page: per pixel column the first, last, smallest and largest sample (M4), so every extreme
survives and a one-sample spike stays visible, where picking every k-th sample (or LTTB) can drop it."""

from __future__ import annotations

import numpy as np


def envelope(times: np.ndarray, values: np.ndarray, columns: int = 800) -> np.ndarray:
    """The indices (ascending) to keep of a signal sampled at times (ascending), drawn `columns` pixels wide: in each
    of `columns` equal stretches of time, its first and last sample and those of its least and greatest finite value.
    At most 4 * columns indices; all of them when there are no more samples than that."""
    times = np.asarray(times, dtype=float)
    values = np.asarray(values, dtype=float)
    n = len(times)
    if columns < 1:
        raise ValueError("envelope: at least one column")
    if n <= 4 * columns:
        return np.arange(n)
    span = times[-1] - times[0]
    column = np.minimum(((times - times[0]) / span * columns).astype(np.int64), columns - 1) if span > 0 else np.zeros(n, np.int64)
    starts = np.flatnonzero(np.diff(column, prepend=-1))  # the first sample of each non-empty column
    ends = np.append(starts[1:], n) - 1
    finite = np.isfinite(values)
    low = np.where(finite, values, np.inf)
    high = np.where(finite, values, -np.inf)
    # the extreme's position within each column: reduceat gives the extreme, a second pass finds its first index
    lo_value = np.minimum.reduceat(low, starts)
    hi_value = np.maximum.reduceat(high, starts)
    per_sample = np.repeat(np.arange(len(starts)), np.diff(np.append(starts, n)))
    is_lo = (low == lo_value[per_sample]) & finite
    is_hi = (high == hi_value[per_sample]) & finite
    lo_at = _first_in_group(is_lo, per_sample, len(starts))
    hi_at = _first_in_group(is_hi, per_sample, len(starts))
    keep = np.concatenate([starts, ends, lo_at[lo_at >= 0], hi_at[hi_at >= 0]])
    # a non-finite sample is kept too (a divergence is data, and the figure marks it), once per column
    nonfinite = _first_in_group(~finite, per_sample, len(starts))
    return np.unique(np.concatenate([keep, nonfinite[nonfinite >= 0]]))


def _first_in_group(flag: np.ndarray, group: np.ndarray, groups: int) -> np.ndarray:
    """Per group, the index of its first sample where flag holds (-1: none)."""
    out = np.full(groups, -1, dtype=np.int64)
    where = np.flatnonzero(flag)
    if len(where):
        g = group[where]
        first = np.flatnonzero(np.diff(g, prepend=-1))
        out[g[first]] = where[first]
    return out

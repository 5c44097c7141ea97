"""Sliding-window minimum over the samples [i + lo, i + hi] of every i, in O(n).

Two algorithms, the same results: `sliding_min` (scipy.ndimage.minimum_filter1d, in C, on samples without NaN; with a
NaN, van Herk / Gil-Werman: the window is cut at block boundaries of its width, each part a prefix or suffix minimum of
its block, so numpy computes it in a few array passes and NaN propagates as numpy's minimum carries it) and
`sliding_min_deque` (Lemire 2006: a monotonic deque, one pass, amortized O(1) a sample, but a Python loop). The
first is the monitor's; the second is kept as the textbook form and an independent check (tests, benchmarks).
Samples past the end of the array take the value `pad`. A maximum is the minimum of the negated samples.
"""

from __future__ import annotations

from collections import deque

import numpy as np
from scipy.ndimage import minimum_filter1d


def sliding_min(x: np.ndarray, lo: int, hi: int, pad: float = np.inf) -> np.ndarray:
    """out[i] = min(x[i + lo .. i + hi]) (closed), samples past the end being `pad`; lo <= hi, both >= 0."""
    n = len(x)
    if n == 0:
        return np.empty(0)
    w = hi - lo + 1
    # the samples each window may reach: x[lo : n + hi], past-the-end ones padded
    y = np.full(n + w - 1, pad, dtype=float)
    have = max(0, min(n - lo, n + w - 1))
    if have:
        y[:have] = x[lo:lo + have]
    if w == 1:
        return y[:n].copy()
    if not np.isnan(y).any():  # scipy's filter in C, 5-10x faster; its comparisons do not carry NaN as numpy's minimum does
        return minimum_filter1d(y, w, mode="constant", cval=pad, origin=-(w // 2))[:n]
    m = -(-len(y) // w) * w
    z = np.full(m, pad, dtype=float)
    z[:len(y)] = y
    blocks = z.reshape(-1, w)
    prefix = np.minimum.accumulate(blocks, axis=1).ravel()  # min from the block's start to j
    suffix = np.minimum.accumulate(blocks[:, ::-1], axis=1)[:, ::-1].ravel()  # min from j to the block's end
    i = np.arange(n)
    # the window y[i .. i + w - 1] spans at most two blocks: the suffix of i's block and the prefix up to i + w - 1
    return np.minimum(suffix[i], prefix[i + w - 1])


def sliding_max(x: np.ndarray, lo: int, hi: int, pad: float = -np.inf) -> np.ndarray:
    return -sliding_min(-np.asarray(x, dtype=float), lo, hi, -pad)


def sliding_min_deque(x, lo: int, hi: int, pad: float = np.inf) -> np.ndarray:
    """The same as sliding_min by Lemire's monotonic deque: indices whose values increase from front to back."""
    n = len(x)
    out = np.empty(n)
    q: deque[int] = deque()
    j = lo  # next sample to enter
    for i in range(n):
        while j <= i + hi and j < n:
            v = x[j]
            while q and x[q[-1]] >= v:
                q.pop()
            q.append(j)
            j += 1
        while q and q[0] < i + lo:
            q.popleft()
        best = x[q[0]] if q else np.inf
        out[i] = min(best, pad) if i + hi >= n else best
    return out

"""Zonotopes c + G B^r (thesis Sec. 4.1.2): the set operations the ZSE needs and their checks.

Generators are stored as rows (G^T, r x n, C-contiguous) so that appending, dropping and
rewriting generators touch contiguous memory.
"""

from __future__ import annotations

import numpy as np

REDUCTIONS = ("combastel", "girard", "pca")


class ZonotopeError(ValueError):
    """A malformed zonotope, strip or estimator set-up; the message says which."""


def check_zonotope(c: np.ndarray, Gt: np.ndarray, name: str) -> tuple[np.ndarray, np.ndarray]:
    c = np.asarray(c, dtype=float)
    Gt = np.asarray(Gt, dtype=float)
    if c.ndim != 1 or Gt.ndim != 2 or Gt.shape[1] != c.size:
        raise ZonotopeError(f"{name}: centre of size {c.size} and generators {Gt.shape} (rows) do not match")
    if not (np.all(np.isfinite(c)) and np.all(np.isfinite(Gt))):
        raise ZonotopeError(f"{name}: non-finite centre or generators")
    return c, Gt


def interval_hull(Gt: np.ndarray) -> np.ndarray:
    """Half-widths rs(G) of the smallest box containing the zonotope (Thm 4.1)."""
    return np.abs(Gt).sum(axis=0)


def support(c: np.ndarray, Gt: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Support function h(d) = d'c + ||G'd||_1 for each column of d: a zonotope is the intersection of its support half-spaces."""
    return d.T @ c + np.abs(Gt @ d).sum(axis=0)


def contains_point(c: np.ndarray, Gt: np.ndarray, x: np.ndarray, tol: float = 1e-9) -> bool:
    """Exact membership by LP feasibility: is there xi in [-1, 1]^r with G xi = x - c?"""
    from scipy.optimize import linprog  # tests and tools only: the FMU's estimator never calls this

    r = Gt.shape[0]
    res = linprog(np.zeros(r), A_eq=Gt.T, b_eq=x - c, bounds=(-1.0 - tol, 1.0 + tol), method="highs")
    return bool(res.status == 0)


def _scores(Gt: np.ndarray, method: str) -> np.ndarray:
    if method == "girard":
        A = np.abs(Gt)
        return A.sum(axis=1) - A.max(axis=1)
    if method in ("combastel", "pca"):
        return np.einsum("ij,ij->i", Gt, Gt)
    raise ZonotopeError(f"unknown reduction '{method}' (available: {', '.join(REDUCTIONS)})")


def _box(rest: np.ndarray, Gt: np.ndarray, method: str) -> np.ndarray:
    """n generators whose zonotope contains that of rest: an axis box, or for pca a box in Gt's principal axes."""
    if method == "pca":
        _, U = np.linalg.eigh(Gt.T @ Gt)
        return U.T * np.abs(rest @ U).sum(axis=0)[:, None]
    return np.diag(np.abs(rest).sum(axis=0))


def reduce_rows(Gt: np.ndarray, r_max: int, method: str = "combastel", out: np.ndarray | None = None) -> np.ndarray:
    """An outer approximation of c + Gt' B with at most r_max generators (Alg. 4.3 and variants).

    combastel: keep the r_max - n longest generators (2-norm), box the rest (Combastel 2003).
    girard:    box the generators closest to axis-aligned segments, smallest ||g||_1 - ||g||_inf (Girard 2005).
    pca:       as combastel, but box the rest in the principal axes of the whole set instead of the
               coordinate axes (an oriented box, tighter when the set is elongated off-axis).
    """
    r, n = Gt.shape
    if r_max < n:
        raise ZonotopeError(f"r_max = {r_max} is below the dimension {n}")
    if out is None or out.shape[0] < r:
        work = np.array(Gt, dtype=float)  # one copy; the input is never modified
    else:
        work = out
        work[:r] = Gt
    if r > r_max:
        reduce_in_place(work, r, r_max, method)
    return work[: min(r, r_max)]


def reduce_in_place(buf: np.ndarray, r: int, r_max: int, method: str) -> tuple[np.ndarray, np.ndarray]:
    """Reduce buf[:r] to buf[:r_max] without moving the kept rows; returns (removed rows, added box rows).

    Only the boxed rows and the tail rows that refill their slots are copied.
    """
    n = buf.shape[1]
    G = buf[:r]
    nbox = r - r_max + n  # generators replaced by the n box generators
    score = _scores(G, method)
    # the nbox lowest scores; equal scores go lowest index first (a stable sort), so every implementation,
    # this one and the C runtime's, drops the same generators
    drop = np.sort(np.argsort(score, kind="stable")[:nbox])
    removed = G[drop].copy()
    added = _box(removed, G, method)
    slots = drop[drop < r_max]  # free slots inside the final range
    dropped_tail = np.zeros(r - r_max, dtype=bool)
    dropped_tail[drop[drop >= r_max] - r_max] = True
    movers = r_max + np.flatnonzero(~dropped_tail)  # kept rows beyond r_max fill the free slots first
    k = movers.size
    buf[slots[:k]] = buf[movers]
    buf[slots[k:]] = added
    return removed, added

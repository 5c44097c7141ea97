"""Multirate zonotopic state estimator (thesis Alg. 4.4) engineered for speed.

Prediction (4.25), one strip update (4.27) per available measurement with the
Frobenius-optimal lambda of Thm 4.6, then order reduction to r_max generators.

The update is exact but reorganized: every strip only needs S = G G^T (n x n), and its
effect on the generators is the product T of the (I - lambda rho^T) factors plus one new
generator sigma*lambda. So the strips run on n x n matrices and the generator matrix
(n x ~1750) is touched once per step: G+ = [T G_w, (T A) G, E]. Results equal those of the
sequential textbook algorithm up to rounding (tested against it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .zonotope import REDUCTIONS, ZonotopeError, check_zonotope, interval_hull, reduce_in_place, reduce_rows

RESYNC_EVERY = 64  # recompute S = G G^T exactly this often; in between it is updated in closed form


@dataclass
class StepReport:
    used: int  # strips applied
    skipped_nonfinite: list[int]  # measurement indices skipped because not finite
    inconsistent: list[int]  # indices whose strip misses the predicted set: skipped, the model is violated


class ZonotopicEstimator:
    """nu_k = A nu_{k-1} + B du_{k-1} + w, y_k = H nu_k + v, w in c_w + G_w B, v in c_v + G_v B."""

    def __init__(self, A, B, H, c_w, G_w, c_v, G_v, r_max: int, reduction: str = "combastel"):
        A, B, H = (np.asarray(M, dtype=float) for M in (A, B, H))
        n = A.shape[0]
        if A.shape != (n, n) or B.ndim != 2 or B.shape[0] != n or H.ndim != 2 or H.shape[1] != n:
            raise ZonotopeError(f"dimensions do not match: A {A.shape}, B {B.shape}, H {H.shape}")
        if not all(np.all(np.isfinite(M)) for M in (A, B, H)):
            raise ZonotopeError("non-finite entries in A, B or H")
        c_w, Gwt = check_zonotope(c_w, np.asarray(G_w, dtype=float).T, "process-noise zonotope W")
        ny = H.shape[0]
        c_v, Gvt = check_zonotope(c_v, np.asarray(G_v, dtype=float).T, "measurement-noise zonotope V")
        if c_w.size != n or c_v.size != ny:
            raise ZonotopeError(f"W has dimension {c_w.size} (state {n}), V has {c_v.size} (measurements {ny})")
        if reduction not in REDUCTIONS:
            raise ZonotopeError(f"unknown reduction '{reduction}' (available: {', '.join(REDUCTIONS)})")
        if not (isinstance(r_max, (int, np.integer)) and r_max >= n):
            raise ZonotopeError(f"r_max must be an integer >= the state dimension {n}, got {r_max!r}")
        self.n, self.ny, self.r_max, self.reduction = n, ny, int(r_max), reduction
        self.A, self.B, self.H = A, B, H
        self.c_w, self.Gwt = c_w, Gwt
        self.sigma = interval_hull(Gvt)  # strip half-widths (Lemma 4.1)
        self.s = -c_v
        self.hull_w = interval_hull(Gwt)
        self.Sw = Gwt.T @ Gwt
        cap = self.r_max + Gwt.shape[0] + ny
        self._buf = [np.zeros((cap, n)), np.zeros((cap, n))]
        self._reduced = np.zeros((self.r_max, n))
        self._eye = np.eye(n)
        self._tmp = np.zeros((cap, n))
        self._ones = np.ones(cap)
        self._cur = 0
        self.r = 0
        self.c = np.zeros(n)
        self.S = np.zeros((n, n))
        self.hull = np.zeros(n)
        self._steps = 0

    # state -------------------------------------------------------------------------------
    @property
    def Gt(self) -> np.ndarray:
        """Generators as rows (a view; copy it to keep it)."""
        return self._buf[self._cur][: self.r]

    def frobenius(self) -> float:
        return float(np.sqrt(np.trace(self.S)))

    def initialize(self, c0, G0, y0=None, available=None) -> StepReport:
        """Set X0_bar and apply the initial update step with y0 (Sec. 4.3.3)."""
        c0, G0t = check_zonotope(c0, np.asarray(G0, dtype=float).T, "initial zonotope X0")
        if c0.size != self.n:
            raise ZonotopeError(f"initial zonotope has dimension {c0.size}, the state has {self.n}")
        G0t = G0t[np.any(G0t != 0.0, axis=1)]  # zero generators carry nothing
        if G0t.shape[0] > self._buf[0].shape[0]:
            G0t = reduce_rows(G0t, self.r_max, self.reduction)
        self._cur, self.r = 0, G0t.shape[0]
        self._buf[0][: self.r] = G0t
        self.c = c0.copy()
        self.S = G0t.T @ G0t
        self.hull = interval_hull(G0t)
        if y0 is None:
            return StepReport(0, [], [])
        return self._update(np.eye(self.n), y0, self._indices(available), predicted_hull=self.hull)

    def step(self, du, y, available=None) -> StepReport:
        """One controller period: predict with du_{k-1}, update with the available entries of y_k."""
        A = self.A
        self.c = A @ self.c + self.B @ np.asarray(du, dtype=float) + self.c_w
        self.S = A @ self.S @ A.T + self.Sw
        predicted_hull = np.abs(A) @ self.hull + self.hull_w  # contains the predicted set's interval hull
        return self._update(A, y, self._indices(available), predicted_hull)

    # internals ---------------------------------------------------------------------------
    def _indices(self, available) -> np.ndarray:
        if available is None:
            return np.arange(self.ny)
        idx = np.flatnonzero(np.asarray(available)) if np.asarray(available).dtype == bool else np.asarray(available, int)
        if idx.size and (idx.min() < 0 or idx.max() >= self.ny):
            raise ZonotopeError(f"measurement index out of range 0..{self.ny - 1}: {idx.tolist()}")
        return idx

    def _update(self, M, y, idx, predicted_hull) -> StepReport:
        """All strips of this step at once, then one pass over the generators: G+ = [T G_w, (T M) G, K Sigma].

        The sequence of Frobenius-optimal strip updates (Thm 4.6) is the sequential form of a
        Kalman update with R = diag(sigma^2): K = S H'(H S H' + R)^-1, T = I - K H, the i-th new
        generator sigma_i K[:, i], S+ = T S. Same sets, a handful of n x n operations.
        """
        y = np.asarray(y, dtype=float)
        if y.shape != (self.ny,):
            raise ZonotopeError(f"measurement vector must have {self.ny} entries, got shape {y.shape}")
        c = self.c
        finite = np.isfinite(y[idx])
        nonfinite = idx[~finite].tolist()
        idx = idx[finite]
        H = self.H[idx]
        innovation = y[idx] + self.s[idx] - H @ c
        miss = np.abs(innovation) > np.abs(H) @ predicted_hull + self.sigma[idx]  # strip misses the predicted box
        inconsistent = idx[miss].tolist()
        if miss.any():
            idx, H, innovation = idx[~miss], H[~miss], innovation[~miss]
        m = idx.size
        if m:
            sigma = self.sigma[idx]
            SH = self.S @ H.T
            K = np.linalg.solve(H @ SH + np.diag(sigma * sigma), SH.T).T
            self.c = c + K @ innovation
            T = self._eye - K @ H
            TM = T @ M
            self.S = T @ self.S
            self.S = 0.5 * (self.S + self.S.T)
        else:
            T, TM = self._eye, M
        src = self._buf[self._cur]
        dst = self._buf[1 - self._cur]
        rw = self.Gwt.shape[0] if M is self.A else 0  # the initial update has no process noise
        if rw:
            np.matmul(self.Gwt, T.T, out=dst[:rw])
        np.matmul(src[: self.r], np.ascontiguousarray(TM.T), out=dst[rw: rw + self.r])
        r = rw + self.r
        if m:
            dst[r: r + m] = (K * sigma).T
            r += m
        self._cur = 1 - self._cur
        if r > self.r_max:
            removed, added = reduce_in_place(dst, r, self.r_max, self.reduction)
            self.S += added.T @ added - removed.T @ removed
            r = self.r_max
        self.r = r
        self._steps += 1
        G = dst[:r]
        if self._steps % RESYNC_EVERY == 0:
            self.S = G.T @ G
        self.hull = self._ones[:r] @ np.abs(G, out=self._tmp[:r])  # rs(G): a BLAS pass, 3x faster than sum(axis=0)
        return StepReport(m, nonfinite, inconsistent)

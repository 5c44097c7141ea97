"""Linearized Kalman filter (thesis Alg. 4.1) on the disturbance-augmented model (4.14)-(4.15).

Joseph-form covariance update, as in the thesis, which keeps P symmetric positive
semidefinite even with the singular measurement covariance of Sec. 5.3 (angles exact).
"""

from __future__ import annotations

import numpy as np

from .zonotope import ZonotopeError


def check_covariance(P: np.ndarray, n: int, name: str, definite: bool = False) -> np.ndarray:
    P = np.asarray(P, dtype=float)
    if P.shape != (n, n):
        raise ZonotopeError(f"{name} must be {n}x{n}, got {P.shape}")
    if not np.all(np.isfinite(P)):
        raise ZonotopeError(f"{name} has non-finite entries")
    if not np.allclose(P, P.T, rtol=1e-10, atol=1e-14):
        raise ZonotopeError(f"{name} is not symmetric")
    low = np.linalg.eigvalsh(P)[0]
    tol = 1e-12 * max(1.0, np.abs(P).max())
    if low < -tol or (definite and low <= tol):
        raise ZonotopeError(f"{name} is not positive {'definite' if definite else 'semidefinite'} (min eigenvalue {low:.3g})")
    return P


class KalmanFilter:
    """nu_k = A nu_{k-1} + B du_{k-1} + w, dy_k = H nu_k + v; w ~ N(0, Pw), v ~ N(0, Pv)."""

    def __init__(self, A, B, H, Pw, Pv, nu0, P0):
        A, B, H = (np.asarray(M, dtype=float) for M in (A, B, H))
        n = A.shape[0]
        if A.shape != (n, n) or B.ndim != 2 or B.shape[0] != n or H.ndim != 2 or H.shape[1] != n:
            raise ZonotopeError(f"dimensions do not match: A {A.shape}, B {B.shape}, H {H.shape}")
        self.A, self.B, self.H = A, B, H
        self.Pw = check_covariance(Pw, n, "P^w")
        self.Pv = check_covariance(Pv, H.shape[0], "P^v")
        self.P = check_covariance(P0, n, "P_0|0")
        self.nu = np.asarray(nu0, dtype=float).copy()
        if self.nu.shape != (n,) or not np.all(np.isfinite(self.nu)):
            raise ZonotopeError(f"initial estimate must be {n} finite numbers")
        self._eye = np.eye(n)

    def step(self, du, dy, available=None) -> list[int]:
        """Predict with du_{k-1}, correct with the finite, available entries of dy_k; returns the skipped indices."""
        A = self.A
        nu = A @ self.nu + self.B @ np.asarray(du, dtype=float)
        P = A @ self.P @ A.T + self.Pw
        dy = np.asarray(dy, dtype=float)
        if dy.shape != (self.H.shape[0],):
            raise ZonotopeError(f"measurement vector must have {self.H.shape[0]} entries, got shape {dy.shape}")
        avail = np.ones(dy.size, dtype=bool) if available is None else np.asarray(available, dtype=bool)
        finite = np.isfinite(dy)
        skipped = np.flatnonzero(avail & ~finite).tolist()
        ok = avail & finite
        if ok.any():
            H, Pv = self.H[ok], self.Pv[np.ix_(ok, ok)]
            Sinn = H @ P @ H.T + Pv
            N = np.linalg.solve(Sinn, H @ P).T  # P H' S^-1 (S symmetric)
            nu = nu + N @ (dy[ok] - H @ nu)
            IKH = self._eye - N @ H
            P = IKH @ P @ IKH.T + N @ Pv @ N.T
            P = 0.5 * (P + P.T)
        self.nu, self.P = nu, P
        return skipped

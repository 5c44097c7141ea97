"""Discrete-time LQR (thesis Sec. 3.3): K from the discrete algebraic Riccati equation."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import solve_discrete_are

from .error_dynamics import DesignError, ErrorDynamics
from .weights import check_weight


@dataclass(frozen=True)
class DLQR:
    K: np.ndarray
    P: np.ndarray
    riccati_residual: float  # max |P - (A'PA + Q - A'PB (B'PB + R)^-1 B'PA)| / max |P|
    spectral_radius: float


def design_dlqr(sys: ErrorDynamics, Q: np.ndarray, R: np.ndarray) -> DLQR:
    n, m = sys.B.shape
    Q = check_weight(Q, n, "Omega_chi", definite=False)
    R = check_weight(R, m, "Omega_u", definite=True)
    A, B = sys.A, sys.B
    try:
        P = solve_discrete_are(A, B, Q, R)
    except (np.linalg.LinAlgError, ValueError) as err:
        raise DesignError(f"the discrete Riccati equation has no stabilizing solution: {err}") from None
    G = B.T @ P @ B + R
    K = np.linalg.solve(G, B.T @ P @ A)
    residual = A.T @ P @ A + Q - A.T @ P @ B @ K - P
    rho = float(np.max(np.abs(np.linalg.eigvals(A - B @ K))))
    if not rho < 1.0:
        raise DesignError(f"the DLQR closed loop is not stable (spectral radius {rho:.6f})")
    return DLQR(K, P, float(np.abs(residual).max() / np.abs(P).max()), rho)

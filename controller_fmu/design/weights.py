"""DLQR weights Omega_chi, Omega_u of thesis Sec. 5.2, with the entries the OCR lost rebuilt.

Printed in Sec. 5.2 (Bryson's rule, weight / (max excursion)^2): x, y, z 20/2^2; phi, theta
1/(pi/2)^2; psi 15/pi^2; gamma 10/(pi/2)^2; alpha 0.01/(pi/2)^2; xdot, ydot, zdot 1/2^2.
Lost: the other rates, the integral weights and Omega_u. They follow Appendix A (A.5), the
same Bryson pattern for the UAV alone (docs/controller.md explains the mapping):
  angular rates of the load and yaw rate, tilt rates  1/(3 pi)^2
  UAV tilt rates gamma_dot (A.5's roll/pitch rates)   5/(3 pi)^2
  integrals of x, y, z errors 30, of the psi error     1
  Omega_u = diag(750/(30 - f_R^eq)^2, 750/(30 - f_L^eq)^2, 5000/2^2, 5000/2^2)
"""

from __future__ import annotations

import numpy as np

PI = np.pi


def omega_chi(vehicle: str = "load") -> np.ndarray:
    """Omega_chi of Sec. 5.2 (the load), or of (A.5) for the UAV alone: x, y, z 20/2^2; phi, theta 10/(pi/2)^2;
    psi 15/pi^2; alpha 0.01/(pi/2)^2; the velocities 1/2^2; roll and pitch rates 5/(3 pi)^2; yaw and tilt rates
    1/(3 pi)^2; integrals 30, 30, 30, 1 (the OCR prints the entries in this order, garbled only in layout)."""
    integrals = [30.0, 30.0, 30.0, 1.0]
    if vehicle == "uav":
        q = [20 / 2**2] * 3 + [10 / (PI / 2) ** 2] * 2 + [15 / PI**2] + [0.01 / (PI / 2) ** 2] * 2
        qd = [1 / 2**2] * 3 + [5 / (3 * PI) ** 2] * 2 + [1 / (3 * PI) ** 2] * 3
        return np.diag(q + qd + integrals)
    q = [20 / 2**2] * 3 + [1 / (PI / 2) ** 2] * 2 + [15 / PI**2] + [10 / (PI / 2) ** 2] * 2 + [0.01 / (PI / 2) ** 2] * 2
    qd = [1 / 2**2] * 3 + [1 / (3 * PI) ** 2] * 3 + [5 / (3 * PI) ** 2] * 2 + [1 / (3 * PI) ** 2] * 2
    return np.diag(q + qd + integrals)


def omega_u(u_eq: np.ndarray) -> np.ndarray:
    f_r, f_l = float(u_eq[0]), float(u_eq[1])
    return np.diag([750 / (30 - f_r) ** 2, 750 / (30 - f_l) ** 2, 5000 / 2**2, 5000 / 2**2])


DELAYED_INPUT_WEIGHT = 1e-2  # of Omega_u, on each delayed input a delay-aware design carries (keeps the weight definite)


def delayed(Q: np.ndarray, R: np.ndarray, d: int) -> np.ndarray:
    """Omega_chi of the delay-aware model (error_dynamics.with_loop_delay): the states keep their weights, each of the
    d delayed inputs gets a small multiple of Omega_u. The LMIs need it definite; the cost is the input's anyway,
    paid when it reaches the plant."""
    from scipy.linalg import block_diag

    return block_diag(Q, *([DELAYED_INPUT_WEIGHT * R] * d))


def check_weight(W: np.ndarray, n: int, name: str, definite: bool) -> np.ndarray:
    """Validate a weight: shape n x n, finite, symmetric, PSD (or PD); raise DesignError naming it."""
    from .error_dynamics import DesignError

    W = np.asarray(W, dtype=float)
    if W.shape != (n, n):
        raise DesignError(f"{name} must be {n}x{n}, got shape {W.shape}")
    if not np.isfinite(W).all():
        raise DesignError(f"{name} has non-finite entries")
    if not np.allclose(W, W.T, rtol=0, atol=1e-12 * max(1.0, np.abs(W).max())):
        raise DesignError(f"{name} must be symmetric")
    low = np.linalg.eigvalsh(W)[0]
    tol = 1e-12 * max(1.0, np.abs(W).max())
    if (definite and low <= tol) or low < -tol:
        kind = "positive definite" if definite else "positive semidefinite"
        raise DesignError(f"{name} must be {kind} (smallest eigenvalue {low:.3g})")
    return W

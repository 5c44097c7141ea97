"""The total control law u = sat(u_tr - K chi) with the feedforward (3.18)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..plant_fmu.model import model
from .error_dynamics import REGULATED


def feedforward(q_tr: np.ndarray, qd_tr: np.ndarray, qdd_tr: np.ndarray, p: np.ndarray) -> np.ndarray:
    """(3.18): u_tr = L_in^+ (M qdd + (C + L_fr) qd + g) at the reference."""
    M, Cqd, g, L_in, L_fr, _ = (np.array(v) for v in model().f_terms(np.r_[q_tr, qd_tr], p))
    rhs = M @ qdd_tr + Cqd.ravel() + L_fr @ qd_tr + g.ravel()
    return np.linalg.lstsq(L_in, rhs, rcond=None)[0]


@dataclass
class StateFeedback:
    """Discrete controller running at T_c: integral states, feedforward, gain, saturation."""

    K: np.ndarray
    Tc: float
    trim_x: np.ndarray
    params: np.ndarray
    limits: tuple[float, float, float] = (0.0, 30.0, 2.0)
    integral: np.ndarray = field(default_factory=lambda: np.zeros(4))

    def reference_state(self, xi, xi_dot, psi=0.0) -> np.ndarray:
        """x_tr: load on the path, the other coordinates at their trim values (Sec. 3.2)."""
        x = self.trim_x.copy()
        x[0:3], x[5] = xi, psi
        x[10:20] = 0.0
        x[10:13] = xi_dot
        return x

    def __call__(self, x, xi, xi_dot, xi_ddot, psi=0.0) -> np.ndarray:
        x_tr = self.reference_state(np.asarray(xi, float), np.asarray(xi_dot, float), psi)
        qdd = np.zeros(10)
        qdd[0:3] = xi_ddot
        u_tr = feedforward(x_tr[:10], x_tr[10:], qdd, self.params)
        chi = np.r_[x - x_tr, self.integral]
        u = u_tr - self.K @ chi
        self.integral = self.integral + self.Tc * (x - x_tr)[list(REGULATED)]
        lo, hi, tau = self.limits
        return np.r_[np.clip(u[:2], lo, hi), np.clip(u[2:], -tau, tau)]

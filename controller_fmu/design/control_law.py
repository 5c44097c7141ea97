"""The total control law u = sat(u_tr - K chi) with the feedforward (3.18). Numpy only: the FMU runs it.

The feedforward is passed in: CasADi at design time (controller_fmu.feedforward), the compiled
library inside the FMU; both come from the same model expressions.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

REGULATED = (0, 1, 2, 5)  # x, y, z, psi: the four degrees of freedom steered along the path

Feedforward = Callable[[np.ndarray, np.ndarray], np.ndarray]  # (x_tr (20), qdd_tr (10)) -> u_tr (4)


@dataclass
class StateFeedback:
    """Discrete controller running at T_c: integral states, feedforward, gain, saturation.

    A delay-aware gain (4 x (nx + 4 + 4 d), error_dynamics.with_loop_delay) also acts on the deviations of the d
    commands sent before, which have not reached the plant yet."""

    K: np.ndarray
    Tc: float
    trim_x: np.ndarray
    feedforward: Feedforward
    limits: tuple[float, float, float] = (0.0, 30.0, 2.0)
    integral: np.ndarray = field(default_factory=lambda: np.zeros(4))
    sent: list = field(default_factory=list)  # deviations du of the last d commands, newest first

    @property
    def loop_delay(self) -> int:
        return (self.K.shape[1] - self.trim_x.size - 4) // 4

    def reference_state(self, xi, xi_dot, psi=0.0, psi_dot=0.0) -> np.ndarray:
        """x_tr: load on the path, the other coordinates at their trim values (Sec. 3.2)."""
        x = self.trim_x.copy()
        half = x.size // 2  # 10 coordinates with the load, 8 for the UAV alone
        x[0:3], x[5] = xi, psi
        x[half:] = 0.0
        x[half:half + 3], x[half + 5] = xi_dot, psi_dot
        return x

    def __call__(self, x, xi, xi_dot, xi_ddot, psi=0.0, psi_dot=0.0) -> np.ndarray:
        x_tr = self.reference_state(np.asarray(xi, float), np.asarray(xi_dot, float), psi, psi_dot)
        qdd = np.zeros(self.trim_x.size // 2)
        qdd[0:3] = xi_ddot
        u_tr = self.feedforward(x_tr, qdd)
        d = self.loop_delay
        if len(self.sent) != d:
            self.sent = [np.zeros(4)] * d
        chi = np.r_[x - x_tr, self.integral, *reversed(self.sent)]  # the oldest command first
        u = u_tr - self.K @ chi
        self.integral = self.integral + self.Tc * (x - x_tr)[list(REGULATED)]
        lo, hi, tau = self.limits
        u = np.r_[np.clip(u[:2], lo, hi), np.clip(u[2:], -tau, tau)]
        if d:
            self.sent = [u - u_tr, *self.sent[:-1]]
        return u

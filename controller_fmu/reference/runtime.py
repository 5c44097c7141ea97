"""The controller+estimator tick in Python: estimator, then u = sat(u_tr - K chi). The reference for the C.

The controller FMU runs the same tick in C (controller_fmu/fmu/c/controller_model.c); this module is
the design-time version the tests hold it to, tick by tick (tests/fmus/test_controller_fmu.py),
and a way to run the controller offline. Everything is computed at build time and passed in as a
bundle of arrays (gains, linearization, estimator matrices). Timing (docs/ports.md): tick k uses the
reference and measurements at t_k and the input applied over the previous tick, u_{k-1}. With a delay-aware
design for d ticks (loop_delay), the measurements at tick k are of the interval the command of k-1-d drove.
"""

from __future__ import annotations

import numpy as np

from ..design.control_law import Feedforward, StateFeedback
from .lkf import KalmanFilter
from .zonotope import REDUCTIONS
from .zse import ZonotopicEstimator

CONTROLLERS = ("dlqr", "mixed")
ESTIMATORS = ("none", "lkf", "zse")


class SetupError(ValueError):
    """A controller set-up the FMU cannot run; the message says which parameter."""


def check_choice(name: str, value: str, allowed: tuple[str, ...]) -> str:
    if value not in allowed:
        raise SetupError(f"unknown {name} '{value}' (available: {', '.join(allowed)})")
    return value


class ControllerRuntime:
    def __init__(self, bundle: dict, controller: str, estimator: str, feedforward: Feedforward,
                 limits=(0.0, 30.0, 2.0), start_position=None, reduction: str = "combastel", loop_delay: int = 0) -> None:
        check_choice("controller", controller, CONTROLLERS)
        self.estimator = check_choice("estimator", estimator, ESTIMATORS)
        check_choice("zse_reduction", reduction, REDUCTIONS)
        lo, hi, tau = limits
        if not (np.isfinite([lo, hi, tau]).all() and lo < hi and tau > 0):
            raise SetupError(f"actuator limits need f_min < f_max and tau_max > 0, got {limits}")
        b = bundle
        self.x_eq, self.u_eq = b["trim_x"], b["trim_u"]
        if f"K_{controller}_d{loop_delay}" not in b:
            raise SetupError(f"no {controller} design for loop_delay_ticks = {loop_delay!r}")
        self.law = StateFeedback(b[f"K_{controller}_d{loop_delay}"], float(b["Tc"]), self.x_eq, feedforward, (lo, hi, tau))
        self.sent = [self.u_eq.copy()] * (loop_delay + 1)  # the commands of the last d + 1 ticks, newest first
        self.k = 0
        self.b = b
        self.reduction = reduction
        self.start = np.zeros(3) if start_position is None else np.asarray(start_position, dtype=float)
        self.filter = None
        self.estimate = self.x_eq.copy()
        self.disturbance = np.zeros(3)
        self.lower = np.full(23, np.nan)
        self.upper = np.full(23, np.nan)
        self.frobenius = 0.0
        self.generators = 0
        self.flags: list[int] = []  # measurement indices skipped in the last step (non-finite or inconsistent)

    def _estimate(self, exact, lkf_q, zse_y, zse_available):
        b = self.b
        du = self.sent[-1] - self.u_eq  # the command that drove the plant over the interval now measured
        if self.estimator == "none":
            self.estimate = np.asarray(exact, dtype=float).copy()
            self.lower = self.upper = np.r_[self.estimate, self.disturbance]
            return
        if self.estimator == "lkf":
            if self.filter is None:  # Sec. 5.3: the initial state is known (at rest at the start position)
                nu0 = np.zeros(23)
                nu0[:3] = self.start - self.x_eq[:3]
                self.filter = KalmanFilter(b["A_nu"], b["B_nu"], b["H_lkf"], b["Pw"], b["Pv"], nu0, b["P0"])
                self.flags = []
            else:
                self.flags = self.filter.step(du, np.asarray(lkf_q, dtype=float) - self.x_eq[:10])
            nu, half = self.filter.nu, 3.0 * np.sqrt(np.clip(np.diag(self.filter.P), 0.0, None))
        else:
            if self.filter is None:  # Sec. 5.4: box around the reference start, then the initial update with y_0
                self.filter = ZonotopicEstimator(b["A_nu"], b["B_nu"], b["H_zse"], np.zeros(23), b["G_w"], b["y_eq"],
                                                 b["G_v"], int(b["r_max"]), self.reduction)
                c0 = np.zeros(23)
                c0[:3] = self._reference_start - self.x_eq[:3]
                report = self.filter.initialize(c0, b["G_x0"], zse_y, zse_available)
            else:
                report = self.filter.step(du, zse_y, zse_available)
            self.flags = report.skipped_nonfinite + report.inconsistent
            nu, half = self.filter.c, self.filter.hull
            self.frobenius, self.generators = self.filter.frobenius(), self.filter.r
        self.estimate = self.x_eq + nu[:20]
        self.disturbance = nu[20:]
        centre = np.r_[self.estimate, self.disturbance]
        self.lower, self.upper = centre - half, centre + half

    def step(self, ref: np.ndarray, exact=None, lkf_q=None, zse_y=None, zse_available=None) -> np.ndarray:
        """ref = [x y z vx vy vz ax ay az psi psi_dot] at t_k; returns u_k (saturated)."""
        ref = np.asarray(ref, dtype=float)
        if self.k == 0:
            self._reference_start = ref[0:3].copy()
        self._estimate(exact, lkf_q, zse_y, zse_available)
        u = self.law(self.estimate, ref[0:3], ref[3:6], ref[6:9], ref[9], ref[10])
        self.sent = [u, *self.sent[:-1]]
        self.k += 1
        return u

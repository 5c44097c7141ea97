"""Closed-loop check on the nonlinear model (not yet through FMUs), for design validation.

The plant is the same RK4 substep the plant FMU compiles (plant_fmu.codegen), evaluated by
CasADi; the controller is the sampled-data law of control_law.StateFeedback at T_c.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ...plant_fmu import codegen
from ..design import feedforward
from ..design.artifact import Design
from ..design.control_law import StateFeedback

_RK4 = None


def _rk4():
    global _RK4
    if _RK4 is None:
        _RK4 = codegen.functions()[1]
    return _RK4


def simulate(design: Design, x0: np.ndarray, stop: float,
             disturbance: Callable[[float], np.ndarray] = lambda t: np.zeros(3),
             substeps: int = 3) -> dict[str, np.ndarray]:
    """Hover set-point at the trim position; returns time, states and applied inputs per tick."""
    rk4 = _rk4()
    ctrl = StateFeedback(design.K, design.Tc, design.trim_x, feedforward.bound(design.params))
    x = np.array(x0, dtype=float)
    n = int(round(stop / design.Tc))
    h = design.Tc / substeps
    ts, xs, us = np.empty(n + 1), np.empty((n + 1, 20)), np.empty((n, 4))
    ts[0], xs[0] = 0.0, x
    hover = design.trim_x[0:3]
    for k in range(n):
        t = k * design.Tc
        u = ctrl(x, hover, np.zeros(3), np.zeros(3), design.trim_x[5])
        d = np.asarray(disturbance(t), dtype=float)
        for _ in range(substeps):
            x = np.array(rk4(x, u, d, design.params, h)).ravel()
        if not np.isfinite(x).all():
            raise RuntimeError(f"closed loop diverged at t = {t:.3f} s")
        ts[k + 1], xs[k + 1], us[k] = t + design.Tc, x, u
    return {"t": ts, "x": xs, "u": us}

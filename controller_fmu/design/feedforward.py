"""The feedforward (3.18) evaluated by CasADi, for design-time simulation and tests.

The same CasADi function is compiled into the FMUs' library (plant_fmu.codegen).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from ...plant_fmu.codegen import feedforward_function


@lru_cache(maxsize=2)
def _function(vehicle: str = "load"):
    return feedforward_function(vehicle)


def feedforward(q_tr: np.ndarray, qd_tr: np.ndarray, qdd_tr: np.ndarray, p: np.ndarray, vehicle: str = "load") -> np.ndarray:
    """(3.18): u_tr = L_in^+ (M qdd + (C + L_fr) qd + g) at the reference (the UAV alone: its own M, C, g, L)."""
    return np.asarray(_function(vehicle)(np.r_[q_tr, qd_tr], qdd_tr, p)).ravel()


def bound(p: np.ndarray, vehicle: str = "load"):
    """A control_law.Feedforward for fixed parameters."""
    n = len(p) and (10 if vehicle == "load" else 8)
    return lambda x_tr, qdd: feedforward(x_tr[:n], x_tr[n:], qdd[:n], p, vehicle)

"""The feedforward (3.18) evaluated by CasADi, for design-time simulation and tests.

The same CasADi function is compiled into the FMUs' library (plant_fmu.codegen).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from ..plant_fmu.codegen import feedforward_function


@lru_cache(maxsize=1)
def _function():
    return feedforward_function()


def feedforward(q_tr: np.ndarray, qd_tr: np.ndarray, qdd_tr: np.ndarray, p: np.ndarray) -> np.ndarray:
    """(3.18): u_tr = L_in^+ (M qdd + (C + L_fr) qd + g) at the reference."""
    return np.asarray(_function()(np.r_[q_tr, qd_tr], qdd_tr, p)).ravel()


def bound(p: np.ndarray):
    """A control_law.Feedforward for fixed parameters."""
    return lambda x_tr, qdd: feedforward(x_tr[:10], x_tr[10:], qdd, p)

"""Design front: build a controller of the thesis from the plant model and save it."""

from __future__ import annotations

import time

import numpy as np

from .artifact import Design
from .dlqr import design_dlqr
from .error_dynamics import error_dynamics
from .weights import omega_chi, omega_u

KINDS = ("dlqr",)


def design(kind: str = "dlqr", Tc: float = 0.012) -> Design:
    from .error_dynamics import DesignError

    if kind not in KINDS:
        raise DesignError(f"unknown controller '{kind}' (available: {', '.join(KINDS)})")
    start = time.perf_counter()
    sys = error_dynamics(Tc)
    Q, R = omega_chi(), omega_u(sys.trim.u)
    result = design_dlqr(sys, Q, R)
    report = {
        "spectral_radius": result.spectral_radius,
        "riccati_residual": result.riccati_residual,
        "gain_norm": float(np.linalg.norm(result.K, 2)),
        "seconds": time.perf_counter() - start,
    }
    return Design(kind, result.K, Tc, sys.trim.x, sys.trim.u, sys.params, sys.A, sys.B, sys.F, Q, R, report)

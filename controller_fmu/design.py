"""Design front: build a controller of the thesis from the plant model and save it."""

from __future__ import annotations

import time

import numpy as np

from .artifact import Design
from .dlqr import design_dlqr
from .error_dynamics import error_dynamics
from .lmi import EPS_REGION, VARPI_REGION, synthesize
from .weights import omega_chi, omega_u

KINDS = ("dlqr", "hinf", "mixed")
MIXED_GAMMA_SQ = 24.0**2  # prescribed H-infinity bound of the mixed design (thesis Sec. 5.2)


def design(kind: str = "dlqr", Tc: float = 0.012, *, use_cache: bool = False, progress=None, vehicle: str = "load") -> Design:
    """Synthesize the thesis's controller of this kind; use_cache reuses a stored identical design.

    progress(str), if given, hears about a synthesis that runs (not about a cache hit). The UAV alone
    (vehicle "uav", Appendix A) has the DLQR of Sec. A.3 only: the thesis gives no H-infinity set-up for it."""
    from ..plant_fmu.vehicles import VEHICLES
    from .error_dynamics import DesignError

    kinds = KINDS if vehicle == "load" else ("dlqr",)
    if kind not in kinds:
        raise DesignError(f"unknown controller '{kind}' for the {vehicle} vehicle (available: {', '.join(kinds)})")
    if use_cache:
        from .cache import cached

        label = kind if vehicle == "load" else f"{vehicle}-{kind}"
        return cached(label, Tc, VEHICLES[vehicle].default_parameters(),
                      lambda: design(kind, Tc, progress=progress, vehicle=vehicle))

    start = time.perf_counter()
    sys = error_dynamics(Tc, vehicle=vehicle)
    Q, R = omega_chi(vehicle), omega_u(sys.trim.u)
    if kind == "dlqr":
        result = design_dlqr(sys, Q, R)
        K = result.K
        report = {"spectral_radius": result.spectral_radius, "riccati_residual": result.riccati_residual}
    else:
        if progress is not None:
            progress(f"synthesizing the {kind} design (LMIs, about 10 s with SDPA; cached afterwards) ...")
        res = synthesize(sys, Q, R, gamma_sq=None if kind == "hinf" else MIXED_GAMMA_SQ, progress=progress)
        K = res.K
        report = {
            "spectral_radius": float(np.abs(res.poles).max()),
            "min_real_pole": float(res.poles.real.min()),
            "regions": {"eps": EPS_REGION, "varpi": VARPI_REGION},
            "gamma_bound": res.gamma_bound,
            "hinf_norm": res.hinf_norm,
            "h2_bound": res.h2_bound,
            "h2_norm": res.h2_norm,
            "solver": res.solver,
            "solver_status": res.status,
            "solver_iterations": res.iterations,
            "solver_seconds": res.seconds,
            "lmi_min_eig": res.lmi_min_eig,
        }
    report["gain_norm"] = float(np.linalg.norm(K, 2))
    report["seconds"] = time.perf_counter() - start
    if progress is not None and kind != "dlqr":
        progress(f"{kind} design synthesized in {report['seconds']:.1f} s ({res.solver}, {res.iterations} iterations, "
                 f"status {res.status})")
    return Design(kind, K, Tc, sys.trim.x, sys.trim.u, sys.params, sys.A, sys.B, sys.F, Q, R, report)

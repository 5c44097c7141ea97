"""Design front: build a controller of the thesis from the plant model and save it."""

from __future__ import annotations

import time

import numpy as np

from .artifact import Design
from .dlqr import design_dlqr
from .error_dynamics import error_dynamics, with_loop_delay
from .lmi import EPS_REGION, VARPI_REGION, synthesize
from .weights import delayed, omega_chi, omega_u

KINDS = ("dlqr", "hinf", "mixed")
MIXED_GAMMA_SQ = 24.0**2  # prescribed H-infinity bound of the mixed design (thesis Sec. 5.2)


def design(kind: str = "dlqr", Tc: float = 0.012, *, use_cache: bool = False, progress=None, vehicle: str = "load",
           loop_delay: int = 0) -> Design:
    """Synthesize the thesis's controller of this kind; use_cache reuses a stored identical design.

    progress(str), if given, hears about a synthesis that runs (not about a cache hit). The UAV alone
    (vehicle "uav", Appendix A) has the DLQR of Sec. A.3 only: the thesis gives no H-infinity set-up for it.
    loop_delay d > 0: the same design made on the model augmented with d ticks of transport delay
    (error_dynamics.with_loop_delay); the gain then also acts on the d inputs still on their way to the plant."""
    from ...plant_fmu.vehicles import VEHICLES
    from .error_dynamics import DesignError

    kinds = KINDS if vehicle == "load" else ("dlqr",)
    if kind not in kinds:
        raise DesignError(f"unknown controller '{kind}' for the {vehicle} vehicle (available: {', '.join(kinds)})")
    if use_cache:
        from .cache import cached

        label = (kind if vehicle == "load" else f"{vehicle}-{kind}") + (f"-d{loop_delay}" if loop_delay else "")
        return cached(label, Tc, VEHICLES[vehicle].default_parameters(),
                      lambda: design(kind, Tc, progress=progress, vehicle=vehicle, loop_delay=loop_delay))

    start = time.perf_counter()
    plain = error_dynamics(Tc, vehicle=vehicle)
    sys = with_loop_delay(plain, loop_delay)
    Q, R = delayed(omega_chi(vehicle), omega_u(plain.trim.u), loop_delay), omega_u(plain.trim.u)
    if kind == "dlqr":
        result = design_dlqr(sys, Q, R)
        K = result.K
        report = {"spectral_radius": result.spectral_radius, "riccati_residual": result.riccati_residual}
    else:
        if progress is not None:
            about = {0: 10, 1: 25, 2: 35}[loop_delay]
            delay = f" for a {loop_delay}-tick loop delay" if loop_delay else ""
            progress(f"synthesizing the {kind} design{delay} (LMIs, about {about} s with SDPA; cached afterwards) ...")
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
        label = f"{kind} design (d = {loop_delay})" if loop_delay else f"{kind} design"
        progress(f"{label} synthesized in {report['seconds']:.1f} s ({res.solver}, {res.iterations} iterations, "
                 f"status {res.status})")
    return Design(kind, K, Tc, sys.trim.x, sys.trim.u, sys.params, sys.A, sys.B, sys.F, Q, R, report, loop_delay)

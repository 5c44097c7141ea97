"""Design front: build a controller of the thesis from the plant model and save it."""

from __future__ import annotations

import time

import numpy as np

from .artifact import Design
from .dlqr import design_dlqr
from .lmi_check import lmi_report
from .problems import KINDS, MIXED_GAMMA_SQ, describe, label, problem


def design(kind: str = "dlqr", Tc: float = 0.012, *, use_cache: bool = False, progress=None, vehicle: str = "load",
           loop_delay: int = 0) -> Design:
    """Synthesize the thesis's controller of this kind; use_cache reuses a stored identical design.

    use_cache: first a design shipped with tiltload (the LMI designs at the default parameters, shipped.py), used
    only if it was made on this very model and every LMI holds at its point here; then the on-disk cache; else
    synthesize and store. progress(str), if given, hears what happens (a synthesis, a shipped design checked).
    The UAV alone (vehicle "uav", Appendix A) has the DLQR of Sec. A.3 only: the thesis gives no H-infinity set-up
    for it. loop_delay d > 0: the same design made on the model augmented with d ticks of transport delay
    (error_dynamics.with_loop_delay); the gain then also acts on the d inputs still on their way to the plant."""
    from .error_dynamics import DesignError

    kinds = KINDS if vehicle == "load" else ("dlqr",)
    if kind not in kinds:
        raise DesignError(f"unknown controller '{kind}' for the {vehicle} vehicle (available: {', '.join(kinds)})")
    if use_cache:
        from ...plant_fmu.vehicles import VEHICLES
        from . import shipped
        from .cache import cached

        found = shipped.find(kind, Tc, vehicle, loop_delay, progress)
        if found is not None:
            return found
        return cached(label(kind, vehicle, loop_delay), Tc, VEHICLES[vehicle].default_parameters(),
                      lambda: design(kind, Tc, progress=progress, vehicle=vehicle, loop_delay=loop_delay))

    start = time.perf_counter()
    sys, Q, R = problem(kind, Tc, vehicle, loop_delay)
    point = None
    if kind == "dlqr":
        result = design_dlqr(sys, Q, R)
        K = result.K
        report = {"spectral_radius": result.spectral_radius, "riccati_residual": result.riccati_residual}
    else:
        from .lmi import synthesize

        if progress is not None:
            delay = f" for a {loop_delay}-tick loop delay" if loop_delay else ""
            progress(f"synthesizing the {kind} design{delay} (LMIs with SDPA; docs/timings.md says how long; cached afterwards) ...")
        res = synthesize(sys, Q, R, gamma_sq=None if kind == "hinf" else MIXED_GAMMA_SQ, progress=progress)
        K, point = res.K, res.point.to_json()
        report = lmi_report(res)
    report["gain_norm"] = float(np.linalg.norm(K, 2))
    report["seconds"] = time.perf_counter() - start
    if progress is not None and kind != "dlqr":
        progress(f"{describe(kind, loop_delay)} synthesized in {report['seconds']:.1f} s ({res.solver}, {res.iterations} "
                 f"iterations, status {res.status})")
    return Design(kind, K, Tc, sys.trim.x, sys.trim.u, sys.params, sys.A, sys.B, sys.F, Q, R, report, loop_delay, point)


__all__ = ["KINDS", "MIXED_GAMMA_SQ", "design", "label", "problem"]

"""The yaw a controller design holds: the design is linearized at psi = 0, so a reference that turns far enough makes
its loop unstable; the largest stable |psi| found by bisection on the closed loop's spectral radius."""

from __future__ import annotations

import math
from functools import cache

import numpy as np

from ..loop.defaults import VEHICLE


@cache
def closed_loop_radius(kind: str, vehicle: str, delay: int, psi: float) -> float:
    """Spectral radius of the loop of design `kind` (made at psi = 0) around the hover trim at yaw psi."""
    from ....controller_fmu.design.error_dynamics import error_dynamics, with_loop_delay
    from ....controller_fmu.design.synthesize import design

    K = design(kind, use_cache=True, vehicle=vehicle, loop_delay=delay).K
    e = with_loop_delay(error_dynamics(0.012, psi=psi, vehicle=vehicle), delay)
    return float(np.abs(np.linalg.eigvals(e.A - e.B @ K)).max())


def yaw_margin(kind: str, vehicle: str = VEHICLE, delay: int = 0) -> float:
    """The largest |psi| (rad, to 0.01) at which the design's loop stays stable (bisection on the spectral radius)."""
    lo, hi = 0.0, math.pi
    if closed_loop_radius(kind, vehicle, delay, hi) < 1:
        return hi
    while hi - lo > 0.01:
        mid = round(0.5 * (lo + hi), 4)
        lo, hi = (mid, hi) if closed_loop_radius(kind, vehicle, delay, mid) < 1 else (lo, mid)
    return lo


def yaw_problem(worst: tuple[float, float], design: tuple[str, int] | None, vehicle: str) -> str | None:
    """One line if the design cannot hold the largest |psi_ref| worst = (psi, its time), else None."""
    psi, when = worst
    if design is None or abs(psi) < 0.05:  # not our controller, or near the design point
        return None
    kind, delay = design
    radius = closed_loop_radius(kind, vehicle, delay, round(abs(psi), 4))
    if radius >= 1:
        return (f"psi_ref reaches {psi:.3g} rad at t = {when:.2f} s; the {kind} design keeps the loop "
                f"stable for |psi| <= {yaw_margin(kind, vehicle, delay):.2f} rad (it is linearized at psi = 0; "
                f"spectral radius {radius:.4f} there)")
    return None

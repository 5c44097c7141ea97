"""What each design of the thesis is made on: its kind, name, model and weights (shared by the synthesis and by the
check of a stored design, so both see the same problem)."""

from __future__ import annotations

from functools import lru_cache

from .error_dynamics import ErrorDynamics, error_dynamics, with_loop_delay
from .weights import delayed, omega_chi, omega_u

KINDS = ("dlqr", "hinf", "mixed")
MIXED_GAMMA_SQ = 24.0**2  # prescribed H-infinity bound of the mixed design (thesis Sec. 5.2)


def label(kind: str, vehicle: str = "load", loop_delay: int = 0) -> str:
    """The name a design is stored under (cache and shipped files): mixed, mixed-d1, uav-dlqr, ..."""
    return (kind if vehicle == "load" else f"{vehicle}-{kind}") + (f"-d{loop_delay}" if loop_delay else "")


def describe(kind: str, loop_delay: int = 0) -> str:
    """The design's name in a sentence: 'mixed design (d = 1)'."""
    return f"{kind} design (d = {loop_delay})" if loop_delay else f"{kind} design"


def problem(kind: str, Tc: float, vehicle: str = "load", loop_delay: int = 0):
    """(model, Omega_chi, Omega_u) a design of this kind is made on."""
    plain = _plain(Tc, vehicle)
    plain = ErrorDynamics(plain.A.copy(), plain.B.copy(), plain.F.copy(), plain.Tc, plain.trim, plain.params.copy())
    sys = with_loop_delay(plain, loop_delay)
    return sys, delayed(omega_chi(vehicle), omega_u(plain.trim.u), loop_delay), omega_u(plain.trim.u)


@lru_cache(maxsize=8)
def _plain(Tc: float, vehicle: str) -> ErrorDynamics:
    """The linearization at the default parameters, computed once per process (CasADi: ~0.1 s; a build asks for it
    for six designs)."""
    return error_dynamics(Tc, vehicle=vehicle)

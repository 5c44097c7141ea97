"""The two plants of the thesis: the UAV with its suspended load (ch. 2) and the UAV alone (Appendix A).

One Table 5.1 parameter set serves both; the UAV alone takes the parameters of its three bodies
(the load's mass, inertia, rod length and joint friction do not exist for it).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import casadi as ca
import numpy as np

from . import interface as I
from . import parameters as P

LOAD_ONLY = ("m_L", "l", "I_L_xx", "I_L_yy", "I_L_zz", "I_L_xy", "I_L_xz", "I_L_yz", "mu_gamma")


@dataclass(frozen=True)
class Vehicle:
    name: str  # "load" or "uav"
    coordinates: tuple[str, ...]
    states: tuple[tuple[str, str, str], ...]  # (name, unit, meaning) of x = [q, q_dot]
    disturbances: tuple[tuple[str, str, str], ...]
    parameters: tuple[str, ...]  # its entries of P.MODEL_PARAMETERS, in their order

    @property
    def nq(self) -> int:
        return len(self.coordinates)

    @property
    def nx(self) -> int:
        return 2 * self.nq

    @cached_property  # read per feasibility check: a search's every point
    def parameter_specs(self) -> tuple[P.ParameterSpec, ...]:
        return tuple(s for s in P.MODEL_PARAMETERS if s.name in self.parameters)

    @cached_property
    def _defaults(self) -> np.ndarray:
        return np.array([s.default for s in self.parameter_specs])

    def default_parameters(self) -> np.ndarray:
        """Its parameter vector at Table 5.1's values (a new array: the caller may change it)."""
        return self._defaults.copy()

    def full_parameters(self, p):
        """The full Table 5.1 vector from this vehicle's own (symbolic or numeric): the entries it lacks are
        their defaults, which its equations never read."""
        if self.parameters == P.PARAMETER_NAMES:
            return p
        own = {name: i for i, name in enumerate(self.parameters)}
        return ca.vertcat(*(p[own[s.name]] if s.name in own else s.default for s in P.MODEL_PARAMETERS))

    def full_vector(self, p) -> np.ndarray:
        """full_parameters of a numeric vector, in numpy (the same numbers, without CasADi's conversions)."""
        p = np.asarray(p, dtype=float).ravel()
        if self.parameters == P.PARAMETER_NAMES:
            return p.copy()
        full = np.array([s.default for s in P.MODEL_PARAMETERS])
        full[[P.index(name) for name in self.parameters]] = p
        return full


LOAD = Vehicle("load", I.COORDINATES, I.STATES, I.DISTURBANCES, P.PARAMETER_NAMES)
UAV = Vehicle("uav", I.UAV_COORDINATES, I.UAV_STATES, I.UAV_DISTURBANCES,
              tuple(n for n in P.PARAMETER_NAMES if n not in LOAD_ONLY))
VEHICLES = {v.name: v for v in (LOAD, UAV)}

"""Hover trim: the equilibrium the controllers and estimators are linearized at.

At rest (q_dot = 0) the equations of motion reduce to L_in(q) u = g(q): ten equations in
phi, theta, gamma_1, gamma_2, alpha_R, alpha_L and the four inputs, for given x, y, z, psi
(the UAV alone: eight, without the gammas). Newton's method with the exact CasADi Jacobian
converges to machine precision.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from . import parameters as P
from .model import model
from .vehicles import VEHICLES


@dataclass(frozen=True)
class Trim:
    """An equilibrium: state, inputs, and the force residual max|L_in u - g| in N (or N m)."""

    x: np.ndarray
    u: np.ndarray
    residual: float
    iterations: int


class TrimError(RuntimeError):
    """Newton's method did not reach an equilibrium."""


def _unknown_coordinates(vehicle: str) -> list[int]:
    """Every coordinate but x, y, z, psi (indices 0, 1, 2, 5 in both vehicles)."""
    return [i for i in range(model(vehicle).nq) if i not in (0, 1, 2, 5)]


def _residual_function(vehicle: str) -> ca.Function:
    m = model(vehicle)
    unknown = _unknown_coordinates(vehicle)
    z = ca.SX.sym("z", m.nq)  # the unknown coordinates, then the four inputs
    pos = ca.SX.sym("pos", 4)  # x, y, z, psi
    q = [None] * m.nq
    for k, i in enumerate((0, 1, 2, 5)):
        q[i] = pos[k]
    for k, i in enumerate(unknown):
        q[i] = z[k]
    u = z[len(unknown):]
    x = ca.vertcat(*q, ca.DM.zeros(m.nq))
    _, _, g, L_in, _, _ = m.f_terms(x, m.p)
    r = L_in @ u - g
    return ca.Function("trim_residual", [z, pos, m.p], [r, ca.jacobian(r, z)])


def hover_trim(p: np.ndarray | None = None, psi: float = 0.0, position=(0.0, 0.0, 0.0),
               tol: float = 1e-12, max_iter: int = 50, vehicle: str = "load") -> Trim:
    """Solve the hover trim at yaw psi; raise TrimError if Newton does not converge.
    p: the vehicle's own parameter vector (default: Table 5.1)."""
    v = VEHICLES[vehicle]
    p = v.default_parameters() if p is None else np.asarray(p, dtype=float)
    full = np.array(ca.DM(v.full_parameters(ca.DM(p)))).ravel()
    P.validate(full)
    f = _residual_function(vehicle)
    pos = np.array([*position, psi], dtype=float)
    masses = ("m_L", "m_1", "m_2", "m_3") if vehicle == "load" else ("m_1", "m_2", "m_3")
    weight = sum(full[P.index(k)] for k in masses) * full[P.index("g")]
    unknown = _unknown_coordinates(vehicle)
    z = np.zeros(v.nq)
    z[len(unknown):len(unknown) + 2] = weight / 2
    res = np.inf
    for it in range(1, max_iter + 1):  # noqa: B007 (it is reported after the loop)
        r, J = (np.array(v) for v in f(z, pos, p))
        r = r.ravel()
        res = float(np.max(np.abs(r)))
        if res <= tol:
            break
        z = z - np.linalg.solve(J, r)
    else:
        raise TrimError(f"hover trim did not converge in {max_iter} iterations (residual {res:.3g})")
    x = np.zeros(v.nx)
    x[[0, 1, 2, 5]] = pos
    x[unknown] = z[:len(unknown)]
    return Trim(x=x, u=z[len(unknown):].copy(), residual=res, iterations=it)

"""Hover trim: the equilibrium the controllers and estimators are linearized at.

At rest (q_dot = 0) the equations of motion reduce to L_in(q) u = g(q): ten equations in
phi, theta, gamma_1, gamma_2, alpha_R, alpha_L and the four inputs, for given x, y, z, psi.
Newton's method with the exact CasADi Jacobian converges to machine precision.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from . import interface as I
from . import parameters as P
from .model import NQ, model

_UNKNOWN_Q = (3, 4, 6, 7, 8, 9)  # phi, theta, gamma_1, gamma_2, alpha_R, alpha_L


@dataclass(frozen=True)
class Trim:
    """An equilibrium: state, inputs, and the force residual max|L_in u - g| in N (or N m)."""

    x: np.ndarray
    u: np.ndarray
    residual: float
    iterations: int

    def as_dict(self) -> dict:
        names = I.COORDINATES
        return {
            "q": dict(zip(names, map(float, self.x[:NQ]))),
            "u": dict(zip(I.INPUT_NAMES, map(float, self.u))),
            "residual": self.residual,
            "iterations": self.iterations,
        }


class TrimError(RuntimeError):
    """Newton's method did not reach an equilibrium."""


def _residual_function() -> ca.Function:
    m = model()
    z = ca.SX.sym("z", 10)
    pos = ca.SX.sym("pos", 4)  # x, y, z, psi
    q = ca.vertcat(pos[0], pos[1], pos[2], z[0], z[1], pos[3], z[2], z[3], z[4], z[5])
    u = z[6:10]
    x = ca.vertcat(q, ca.DM.zeros(NQ))
    _, _, g, L_in, _, _ = m.f_terms(x, m.p)
    r = L_in @ u - g
    return ca.Function("trim_residual", [z, pos, m.p], [r, ca.jacobian(r, z)])


def hover_trim(p: np.ndarray | None = None, psi: float = 0.0, position=(0.0, 0.0, 0.0),
               tol: float = 1e-12, max_iter: int = 50) -> Trim:
    """Solve the hover trim at yaw psi; raise TrimError if Newton does not converge."""
    p = P.default_vector() if p is None else np.asarray(p, dtype=float)
    P.validate(p)
    f = _residual_function()
    pos = np.array([*position, psi], dtype=float)
    weight = (p[P.index("m_L")] + sum(p[P.index(k)] for k in ("m_1", "m_2", "m_3"))) * p[P.index("g")]
    z = np.zeros(10)
    z[6:8] = weight / 2
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
    x = np.zeros(2 * NQ)
    x[[0, 1, 2, 5]] = pos
    x[list(_UNKNOWN_Q)] = z[:6]
    return Trim(x=x, u=z[6:10].copy(), residual=res, iterations=it)

"""Hover trim: the equilibrium the controllers and estimators are linearized at.

At rest (q_dot = 0) the equations of motion reduce to L_in(q) u = g(q): ten equations in
phi, theta, gamma_1, gamma_2, alpha_R, alpha_L and the four inputs, for given x, y, z, psi
(the UAV alone: eight, without the gammas). Newton's method with the exact CasADi Jacobian
converges to machine precision. The same residual with the tracked coordinates moving (their rates and the load's
acceleration given, the others at rest) is the trim along a path the feasibility check solves (newton).
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from functools import cache

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


TRACKED = (0, 1, 2, 5)  # x, y, z, psi: the coordinates a reference gives (in both vehicles)


def unknown_coordinates(vehicle: str) -> list[int]:
    """Every coordinate but x, y, z, psi: what a trim solves for, besides the inputs."""
    return [i for i in range(model(vehicle).nq) if i not in TRACKED]


def _residual_functions(vehicle: str) -> tuple[ca.Function, ca.Function]:
    """The residual L_in u - (M qdd + C qd + L_fr qd + g) and its Jacobian in z (the unknown coordinates, then the four
    inputs), at the tracked coordinates of ref = [x, y, z, psi, their rates, the load's acceleration x, y, z] with
    every other coordinate at rest: the hover trim (ref's rates and acceleration 0) or the trim along a path; and the
    residual alone, from the same expressions (a quarter of the operations: Newton's last evaluation needs no Jacobian)."""
    m = model(vehicle)
    unknown = unknown_coordinates(vehicle)
    z = ca.SX.sym("z", m.nq)
    ref = ca.SX.sym("ref", 11)
    q, qd, qdd = [None] * m.nq, [0] * m.nq, [0] * m.nq
    for k, i in enumerate(TRACKED):
        q[i], qd[i] = ref[k], ref[4 + k]
    for k, i in enumerate(unknown):
        q[i] = z[k]
    for k in range(3):
        qdd[k] = ref[8 + k]
    M, Cqd, g, L_in, L_fr, _ = m.f_terms(ca.vertcat(*q, *qd), m.p)
    r = L_in @ z[len(unknown):] - (M @ ca.vertcat(*qdd) + Cqd + L_fr @ ca.vertcat(*qd) + g)
    return (ca.Function("trim_residual", [z, ref, m.p], [r, ca.jacobian(r, z)]),
            ca.Function("trim_residual_value", [z, ref, m.p], [r]))


@cache
def residual_functions(vehicle: str) -> tuple[ca.Function, ca.Function]:
    """The trim residual with its Jacobian, and alone (_residual_functions), built once per vehicle."""
    return _residual_functions(vehicle)


def residual_function(vehicle: str) -> ca.Function:
    """The trim residual and its Jacobian (_residual_functions)."""
    return residual_functions(vehicle)[0]


class _Residual:
    """The trim residual called through CasADi's buffer interface (into arrays of ours: no DM made or converted, 25
    against 67 us a call; the same virtual machine, so the same bits); one per thread, as its arrays are shared."""

    def __init__(self, vehicle: str) -> None:
        f = residual_function(vehicle)
        self.buffer, self.call = f.buffer()
        self.z, self.ref, self.p = (np.zeros(f.nnz_in(k)) for k in range(3))
        self.r, self.nonzeros = np.zeros(f.nnz_out(0)), np.zeros(f.nnz_out(1))
        rows, cols = f.sparsity_out(1).get_triplet()
        self.rows, self.cols, self.shape = np.array(rows), np.array(cols), f.sparsity_out(1).shape
        for k, a in enumerate((self.z, self.ref, self.p)):
            self.buffer.set_arg(k, memoryview(a))
        self.buffer.set_res(0, memoryview(self.r))
        self.buffer.set_res(1, memoryview(self.nonzeros))

    def __call__(self, z, ref, p) -> tuple[np.ndarray, np.ndarray]:
        """(residual, its dense Jacobian), new arrays (structural zeros 0.0, as a DM made dense)."""
        self.z[:], self.ref[:], self.p[:] = z, ref, p
        self.call()
        J = np.zeros(self.shape)
        J[self.rows, self.cols] = self.nonzeros
        return self.r.copy(), J


_local = threading.local()


def _residual(vehicle: str) -> _Residual:
    cached = _local.__dict__.setdefault("residuals", {})
    if vehicle not in cached:
        cached[vehicle] = _Residual(vehicle)
    return cached[vehicle]


def newton(vehicle: str, z: np.ndarray, ref: np.ndarray, p: np.ndarray, tol: float, max_iter: int):
    """Newton's method on the trim residual from z: (z, residual, iterations), or None when it does not reach tol
    within max_iter (or meets a singular Jacobian or a value that is not finite)."""
    f = _residual(vehicle)
    for it in range(1, max_iter + 1):
        r, J = f(z, ref, p)
        if not np.all(np.isfinite(r)):
            return None
        res = float(np.max(np.abs(r)))
        if res <= tol:
            return z, res, it
        try:
            z = z - np.linalg.solve(J, r)
        except np.linalg.LinAlgError:
            return None
    return None


def hover_trim(p: np.ndarray | None = None, psi: float = 0.0, position=(0.0, 0.0, 0.0),
               tol: float = 1e-12, max_iter: int = 50, vehicle: str = "load", solve=None) -> Trim:
    """Solve the hover trim at yaw psi; raise TrimError if Newton does not converge.
    p: the vehicle's own parameter vector (default: Table 5.1). solve(z, ref, p, tol, max_iter): newton's steps taken
    elsewhere, the same bits (the feasibility check's, compiled: master/app/feasibility/trim_residual.py); None: newton."""
    v = VEHICLES[vehicle]
    p = v.default_parameters() if p is None else np.asarray(p, dtype=float)
    full = v.full_vector(p)
    P.validate(full)
    pos = np.array([*position, psi], dtype=float)
    masses = ("m_L", "m_1", "m_2", "m_3") if vehicle == "load" else ("m_1", "m_2", "m_3")
    weight = sum(full[P.index(k)] for k in masses) * full[P.index("g")]
    unknown = unknown_coordinates(vehicle)
    z = np.zeros(v.nq)
    z[len(unknown):len(unknown) + 2] = weight / 2
    ref = np.r_[pos, np.zeros(7)]
    found = solve(z, ref, p, tol, max_iter) if solve is not None else newton(vehicle, z, ref, p, tol, max_iter)
    if found is None:
        raise TrimError(f"hover trim did not converge in {max_iter} iterations")
    z, res, it = found
    x = np.zeros(v.nx)
    x[list(TRACKED)] = pos
    x[unknown] = z[:len(unknown)]
    return Trim(x=x, u=z[len(unknown):].copy(), residual=res, iterations=it)

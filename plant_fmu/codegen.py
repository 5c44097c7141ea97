"""Generate the plant's C code with CasADi (build time only): the one source of the compiled model.

The native plant FMU compiles tl_plant_gen.c (one RK4 substep and the diagnostic outputs) into
its binary; the controller FMU compiles the feedforward (3.18) into its own.
"""

from __future__ import annotations

from pathlib import Path

import casadi as ca

from ..native_fmu import casadi_c
from .model import ND, NU, model

PLANT_STEM = "tl_plant_gen"


def locked_accelerations(m, x, u, d, p, stuck):
    """q_dd with the tilt joints whose `stuck` entry is 1 held (a servo stuck at its angle).

    The servo torques' generalized forces act on their own tilt joints only (L_in's last two columns),
    so a stuck joint is the servo torque that makes its acceleration zero: with G = M^-1 L_tau,
    q_dd = q_dd_free + G dtau, and dtau solves the stuck rows of that (unstuck ones keep dtau = 0).
    """
    f = ca.Function("free", [m.x, m.u, m.d, m.p], [m.qdd, ca.solve(m.M, m.L_in[:, 2:4])])
    qdd_free, G = f(x, u, d, p)
    tilt = slice(m.nq - 2, m.nq)  # alpha_R, alpha_L: the last two coordinates of both vehicles
    S = ca.diag(stuck)
    A = S @ G[tilt, :] + ca.diag(1 - stuck)
    dtau = ca.solve(A, -S @ qdd_free[tilt])
    return qdd_free + G @ dtau, G


def _rk4(name: str, rhs: ca.Function, n_extra: int, vehicle: str) -> ca.Function:
    """One RK4 substep of rhs(x, u, d, p[, extra]) over h."""
    m = model(vehicle)
    x, u, d = ca.MX.sym("x", m.nx), ca.MX.sym("u", NU), ca.MX.sym("d", ND)
    p, h = ca.MX.sym("p", m.p.numel()), ca.MX.sym("h")
    extra = [ca.MX.sym("s", n_extra)] if n_extra else []
    k1 = rhs(x, u, d, p, *extra)
    k2 = rhs(x + h / 2 * k1, u, d, p, *extra)
    k3 = rhs(x + h / 2 * k2, u, d, p, *extra)
    k4 = rhs(x + h * k3, u, d, p, *extra)
    return ca.Function(name, [x, u, d, p, h, *extra], [x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)])


def functions(vehicle: str = "load") -> list[ca.Function]:
    """The right-hand side, one RK4 substep and the diagnostic outputs, with CSE applied."""
    m = model(vehicle)
    rhs = ca.Function("tl_plant_rhs", [m.x, m.u, m.d, m.p], [ca.cse(m.xdot)], ["x", "u", "d", "p"], ["xdot"])
    out = ca.Function("tl_plant_out", [m.x, m.p], [ca.cse(m.diagnostics)], ["x", "p"], ["y"])
    return [rhs, _rk4("tl_plant_rk4", rhs, 0, vehicle), out]


def stuck_rk4_function(vehicle: str = "load") -> ca.Function:
    """The RK4 substep with tilt joints held: (x, u, d, p, h, stuck), stuck = [right, left], 1 for a held joint.

    A separate function: the solve it needs costs more than the free model, which runs whenever no servo is stuck.
    """
    m = model(vehicle)
    xs, us, ds, ps, ss = ca.SX.sym("x", m.nx), ca.SX.sym("u", NU), ca.SX.sym("d", ND), ca.SX.sym("p", m.p.numel()), ca.SX.sym("s", 2)
    qdd, _ = locked_accelerations(m, xs, us, ds, ps, ss)
    rhs_stuck = ca.Function("tl_plant_rhs_stuck", [xs, us, ds, ps, ss], [ca.cse(ca.vertcat(xs[m.nq:], qdd))])
    return _rk4("tl_plant_rk4_stuck", rhs_stuck, 2, vehicle)


def stick_function(vehicle: str = "load") -> ca.Function:
    """The impulse that stops the newly stuck tilt joints: q_dot += G lambda with the stuck joints' rates to zero."""
    m = model(vehicle)
    x, p, s = ca.SX.sym("x", m.nx), ca.SX.sym("p", m.p.numel()), ca.SX.sym("s", 2)
    f = ca.Function("g", [m.x, m.p], [ca.solve(m.M, m.L_in[:, 2:4])])
    G = f(x, p)
    qd = x[m.nq:]
    tilt = slice(m.nq - 2, m.nq)
    S = ca.diag(s)
    lam = ca.solve(S @ G[tilt, :] + ca.diag(1 - s), -S @ qd[tilt])
    return ca.Function("tl_plant_stick", [x, p, s], [ca.cse(ca.vertcat(x[:m.nq], qd + G @ lam))], ["x", "p", "s"], ["x_stuck"])


def plant_sources(directory: Path, vehicle: str = "load") -> list[Path]:
    """tl_plant_gen.c/.h and its sizes header (with the model's dimensions) for the plant FMU."""
    _, rk4, out = functions(vehicle)
    m = model(vehicle)
    dims = {"TL_PLANT_NX": m.nx, "TL_PLANT_NP": m.p.numel(), "TL_PLANT_NY": out.size1_out(0)}
    return casadi_c.generate([rk4, out, stuck_rk4_function(vehicle), stick_function(vehicle)], directory, PLANT_STEM, dims)


def feedforward_function(vehicle: str = "load") -> ca.Function:
    """(3.18) u_tr = L_in^+ (M qdd + (C + L_fr) qd + g) at the reference state, for the controller FMU."""
    m = model(vehicle)
    x, qdd = ca.SX.sym("x", m.nx), ca.SX.sym("qdd", m.nq)
    M, Cqd, g, L_in, L_fr, _ = m.f_terms(x, m.p)
    rhs = M @ qdd + Cqd + L_fr @ x[m.nq:] + g
    u = ca.solve(L_in.T @ L_in, L_in.T @ rhs)  # least squares: L_in has full column rank
    return ca.Function("tl_feedforward", [x, qdd, m.p], [ca.cse(u)], ["x", "qdd", "p"], ["u"])

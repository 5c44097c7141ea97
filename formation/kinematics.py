"""The formation's cooperative dual task-space (Sec. B.1) and its two controllers (Sec. B.3.1-B.3.2).

rho_S = [x y z psi] of the leader sigma, then of the followers zeta and tau (12 coordinates);
x_S = [vec8(x_sigma); vec8(x_r); vec8(x_a^sigma)] (24) with x_r = x_zeta* x_tau (B.2),
x_a = x_zeta x_r^(1/phi) (B.3), x_a^sigma = x_sigma* x_a (B.6). The Jacobian J_S of (B.9) and the
term J_S' rho_S' of (B.10) are the exact derivatives of these maps (CasADi), so they need no
hand-derived (B.4)-(B.8), which the tests check them against.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from . import dualquat as dq

AGENTS = ("sigma", "zeta", "tau")  # leader, followers
PHI = 3.0  # the phi-th part of x_r that frame a sits at (Sec. B.4)


@dataclass(frozen=True)
class Gains:
    """Table B.1: backstepping K_A, K_B, K_C; TSID K_1, K_2 (each times the 24 x 24 identity)."""

    K_A: float = 1.2
    K_B: float = 0.1
    K_C: float = 0.1
    K_1: float = 1.3
    K_2: float = 1.12


def task_pose(rho):
    """x_S(rho_S) of (B.9)."""
    x = [dq.pose(rho[4 * i:4 * i + 3], rho[4 * i + 3]) for i in range(3)]
    x_sigma, x_zeta, x_tau = x
    x_r = dq.mul(dq.conj(x_zeta), x_tau)
    x_a = dq.mul(x_zeta, dq.power(x_r, 1.0 / PHI))
    x_a_sigma = dq.mul(dq.conj(x_sigma), x_a)
    return ca.vertcat(x_sigma, x_r, x_a_sigma)


def references(t):
    """x_d(t) of Sec. B.4: x_sigma_d = 1 + eps 1/2 [2t i + (cos 0.2t - 1) k], x_r_d = 1 + eps 1/2 [3 cos 0.3t j +
    3 sin 0.3t k], x_a_d^sigma = 1 + eps 1/2 (-i), each vec8."""
    one = ca.vertcat(1, 0, 0, 0)
    sigma = ca.vertcat(one, 0, t, 0, 0.5 * (ca.cos(0.2 * t) - 1))
    relative = ca.vertcat(one, 0, 0, 1.5 * ca.cos(0.3 * t), 1.5 * ca.sin(0.3 * t))
    absolute = ca.vertcat(one, 0, -0.5, 0, 0)
    return ca.vertcat(sigma, relative, absolute)


def formation_functions(gains: Gains = Gains()) -> list[ca.Function]:
    """tl_formation(rho, rho_dot, e_C, t, law, d_acc) -> (rho_ddot, e_B, e_A): law 0 backstepping (B.15), 1 TSID (B.16).

    e_B is the integrand of e_C (the caller integrates it); d_acc (12) is added to rho_ddot (the acceleration
    disturbances of Sec. B.4). The pseudo-inverse of the full-column-rank J_S (24 x 12) is (J'J)^-1 J'."""
    rho, rho_dot = ca.SX.sym("rho", 12), ca.SX.sym("rho_dot", 12)
    e_C, t, law, d_acc = ca.SX.sym("e_C", 24), ca.SX.sym("t"), ca.SX.sym("law"), ca.SX.sym("d_acc", 12)
    x_S = task_pose(rho)
    J = ca.jacobian(x_S, rho)
    x_B = ca.mtimes(J, rho_dot)
    Jdot_rhodot = ca.mtimes(ca.jacobian(x_B, rho), rho_dot)  # J_S' rho_S'
    x_d = references(t)
    xd_dot = ca.jacobian(x_d, t)
    xd_ddot = ca.jacobian(xd_dot, t)
    e_A = x_S - x_d
    eA_dot = x_B - xd_dot
    Phi = -gains.K_A * e_A + xd_dot
    e_B = x_B - Phi
    Phi_dot = -gains.K_A * eA_dot + xd_ddot
    JtJ = ca.mtimes(J.T, J)

    def pinv(v):
        return ca.solve(JtJ, ca.mtimes(J.T, v))

    # (B.15): J_S' J_S^+ [e_B + Phi] = J_S' J_S^+ x_B = J_S' rho_dot (x_B is in the range of J_S)
    backstepping = pinv(-gains.K_B * e_B + Phi_dot - Jdot_rhodot - gains.K_C * e_C - e_A)
    tsid = pinv(xd_ddot - Jdot_rhodot - gains.K_1 * eA_dot - gains.K_2 * e_A)
    rho_ddot = ca.if_else(law < 0.5, backstepping, tsid) + d_acc
    return [ca.Function("tl_formation", [rho, rho_dot, e_C, t, law, d_acc], [rho_ddot, e_B, e_A],
                        ["rho", "rho_dot", "e_C", "t", "law", "d_acc"], ["rho_ddot", "e_B", "e_A"])]


def formation_start(t: float = 0.0) -> np.ndarray:
    """rho_S of the formation the references describe at t (every yaw 0): where the UAVs should be."""
    sigma = np.array([2 * t, 0.0, np.cos(0.2 * t) - 1])
    rel = np.array([0.0, 3 * np.cos(0.3 * t), 3 * np.sin(0.3 * t)])
    a = sigma + np.array([-1.0, 0.0, 0.0])
    zeta = a - rel / PHI
    tau = zeta + rel
    return np.r_[sigma, 0.0, zeta, 0.0, tau, 0.0]

"""Measurement models of the thesis: q (4.12) for the LKF scenario and pi(x) (4.22) for the ZSE scenario.

One implementation, in CasADi, used three ways: the estimators take its Jacobian at the trim
(H_d of Sec. 4.3.3), the sensor FMU evaluates it (compiled C) on the plant's state, and the
tests compare it with an independent numpy kinematics. Angular velocities are derived as
vex(R^T dR/dt) from the same rotation matrices as the plant, never transcribed.
"""

from __future__ import annotations

from functools import lru_cache

import casadi as ca
import numpy as np

from ..plant_fmu.kinematics import body_angular_velocity, build, euler_zyx
from ..plant_fmu.parameters import MODEL_PARAMETERS

# y of (4.22), in the thesis's order (footnote 5 of Sec. 5.4): 1-3 xi_B, 4-6 eta_B, 7-9 omega_IB^B,
# 10-12 d_BL^B, 13-14 alpha_R, alpha_L, 15-16 their rates.
ZSE_OUTPUTS = ("x_B", "y_B", "z_B", "phi_B", "theta_B", "psi_B", "p_B", "q_B", "r_B",
               "d_BL_x", "d_BL_y", "d_BL_z", "alpha_R", "alpha_L", "alpha_R_dot", "alpha_L_dot")
NY_ZSE = len(ZSE_OUTPUTS)
NY_LKF = 10  # q itself (4.12)


def _pi_expr(x: ca.SX, p: ca.SX) -> ca.SX:
    q, qd = x[:10], x[10:]
    kin = build(q, p)
    omega_B = kin.R_B_L.T @ body_angular_velocity(kin.R_L, q, qd) + body_angular_velocity(kin.R_B_L, q, qd)  # (4.20)
    d_BL = kin.R_B.T @ (q[0:3] - kin.o_B)  # (4.21): the load seen from B, in B
    return ca.vertcat(kin.o_B, euler_zyx(kin.R_B), omega_B, d_BL, q[8], q[9], qd[8], qd[9])


@lru_cache(maxsize=1)
def pi_function() -> ca.Function:
    """pi(x, p) -> (y in R^16 of (4.22), its Jacobian H_d)."""
    x = ca.SX.sym("x", 20)
    p = ca.SX.sym("p", len(MODEL_PARAMETERS))
    y = _pi_expr(x, p)
    return ca.Function("tl_pi_jac", [x, p], [y, ca.jacobian(y, x)], ["x", "p"], ["y", "H"])


def uav_pi_expr(x: ca.SX) -> ca.SX:
    """(A.3) for the UAV alone: y = H_d x = [q; eta_dot; alpha_R_dot; alpha_L_dot] (13 of its 16 states)."""
    return ca.vertcat(x[0:8], x[11:14], x[14:16])


def pi_codegen_function(vehicle: str = "load") -> ca.Function:
    """pi alone, for the compiled library the sensor FMU calls: (x, p) -> y for either vehicle."""
    from ..plant_fmu.vehicles import VEHICLES

    v = VEHICLES[vehicle]
    x = ca.SX.sym("x", v.nx)
    p = ca.SX.sym("p", len(v.parameters))
    y = _pi_expr(x, p) if vehicle == "load" else uav_pi_expr(x)
    return ca.Function("tl_pi", [x, p], [ca.cse(y)], ["x", "p"], ["y"])


def pi(x: np.ndarray, p: np.ndarray) -> np.ndarray:
    return np.asarray(pi_function()(x, p)[0]).ravel()


def pi_jacobian(x: np.ndarray, p: np.ndarray) -> np.ndarray:
    """H_d = d pi / d x at x (16 x 20), thesis Sec. 4.3.3."""
    return np.asarray(pi_function()(x, p)[1])


def lkf_matrix() -> np.ndarray:
    """(4.12): y = [I 0] x."""
    return np.hstack([np.eye(NY_LKF), np.zeros((NY_LKF, 10))])

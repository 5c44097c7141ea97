"""The thesis's estimator set-ups (Sec. 5.3 and 5.4; Sec. A.4 for the UAV alone) on the
disturbance-augmented linear model (4.14).

nu = [dx (20, or 16); d (3)], A_nu = [[A_d, F_d], [0, I]], B_nu = [B_d; 0], from the same ZOH
linearization at the trim as the controllers (period T_c).
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from ...plant_fmu.linearize import linearize, zoh
from ...plant_fmu.trim import Trim, hover_trim
from ...plant_fmu.vehicles import VEHICLES
from ...sensor_fmu import measurement

NNU = 23
R_MAX = 75 * NNU  # order limit of Sec. 5.4: 75 times the dimension


@dataclass(frozen=True)
class AugmentedModel:
    A: np.ndarray  # 23 x 23
    B: np.ndarray  # 23 x 4
    Tc: float
    trim: Trim
    params: np.ndarray


def augmented_model(Tc: float = 0.012, p: np.ndarray | None = None, vehicle: str = "load") -> AugmentedModel:
    v = VEHICLES[vehicle]
    p = v.default_parameters() if p is None else np.asarray(p, dtype=float)
    trim = hover_trim(p, vehicle=vehicle)
    lin = linearize(trim.x, trim.u, p, vehicle=vehicle)
    Ad, BF = zoh(lin.A, np.hstack([lin.B, lin.F]), Tc)
    A = np.block([[Ad, BF[:, 4:]], [np.zeros((3, v.nx)), np.eye(3)]])
    B = np.vstack([BF[:, :4], np.zeros((3, 4))])
    return AugmentedModel(A, B, Tc, trim, p)


@dataclass(frozen=True)
class LKFSetup:
    H: np.ndarray  # 10 x 23
    Pw: np.ndarray
    Pv: np.ndarray
    P0: np.ndarray


def lkf_setup(position_sigma: float = 0.05) -> LKFSetup:
    """Sec. 5.3: P0 = 0.01 I, P^w = 1e-5 I, P^v = diag(sigma^2 I_3, 0_7) (only the position is noisy)."""
    H = np.hstack([measurement.lkf_matrix(), np.zeros((10, 3))])
    Pv = np.zeros((10, 10))
    Pv[:3, :3] = position_sigma**2 * np.eye(3)
    return LKFSetup(H, 1e-5 * np.eye(NNU), Pv, 0.01 * np.eye(NNU))


# Sec. 5.4 (the OCR's lists, in the state order x y z phi theta psi g1 g2 aR aL, their rates, d)
G_W_DIAG = np.array([1e-4] * 13 + [0.01] * 3 + [0.05] * 2 + [1e-4] * 2 + [0.01] * 3)
G_V_DIAG = np.array([0.18, 0.18, 0.612, 3.1416e-3, 3.1416e-3, 0.03, 19.872e-3, 19.872e-3, 0.24,
                     0.006, 0.006, 0.06, 6.8067e-3, 6.8067e-3, 0.6093, 0.6093])


@dataclass(frozen=True)
class ZSESetup:
    H: np.ndarray  # 16 x 23: [H_d 0]
    y_eq: np.ndarray  # pi(x_eq), the centre of V_bar
    G_w: np.ndarray
    G_v: np.ndarray
    G_x0: np.ndarray
    r_max: int


# Sec. A.4, the UAV alone (state order x y z phi theta psi aR aL, their rates; y of (A.3))
UAV_G_W_DIAG = np.array([1e-4] * 5 + [1e-3] + [1e-4] * 5 + [2e-3, 2e-3, 1e-2] + [1e-4] * 2 + [0.1, 0.1, 0.2])
UAV_G_V_DIAG = np.array([0.15, 0.15, 0.51] + [5.15e-3] * 3 + [5.67e-3] * 2 + [5.15e-3] * 3 + [0.50772] * 2)
UAV_R_MAX = 50 * 19  # order limit of Sec. A.4: fifty times the dimension


def zse_setup(model: AugmentedModel, vehicle: str = "load") -> ZSESetup:
    """Sec. 5.4: W_bar = 0 + G_w B^23, V_bar = pi(x_eq) + G_v B^16, X0_bar box, r_max = 75 n.
    Sec. A.4 (the UAV alone): W_bar = 0 + G_w B^19, V_bar = H_d x_eq + G_v B^13, r_max = 50 n."""
    if vehicle == "uav":
        x_eq = model.trim.x
        H_d = np.asarray(ca.Function("H", [x := ca.SX.sym("x", 16)], [ca.jacobian(measurement.uav_pi_expr(x), x)])(x_eq))
        q_eq = x_eq[:8]
        x0 = np.concatenate([[0.5] * 3, 0.2 * np.abs(q_eq[3:5]), [np.pi / 180], 0.2 * np.abs(q_eq[6:8]), [0.02] * 11])
        return ZSESetup(np.hstack([H_d, np.zeros((13, 3))]), H_d @ x_eq, np.diag(UAV_G_W_DIAG), np.diag(UAV_G_V_DIAG),
                        np.diag(x0), UAV_R_MAX)
    x_eq, p = model.trim.x, model.params
    H = np.hstack([measurement.pi_jacobian(x_eq, p), np.zeros((measurement.NY_ZSE, 3))])
    q_eq = x_eq[:10]
    x0 = np.concatenate([[0.5] * 3, 0.2 * np.abs(q_eq[3:5]), [np.pi / 180], 0.2 * np.abs(q_eq[6:10]), [0.02] * 13])
    return ZSESetup(H, measurement.pi(x_eq, p), np.diag(G_W_DIAG), np.diag(G_V_DIAG), np.diag(x0), R_MAX)

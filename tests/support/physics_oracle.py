"""An independent numpy implementation of the system's kinematics, for checking the FMU.

Written from the thesis's own formulas (rotation matrices of Sec. 2.2, W_eta of (2.17),
Q of (2.18), relative rates (2.20)-(2.21)), not from the project's CasADi code: energies,
momenta and thrust directions computed here from the FMU's state outputs are a second
opinion on the model, not a copy of it.
"""

from __future__ import annotations

import numpy as np

TABLE_5_1 = {
    "m": [0.05, 1.70249, 0.13973, 0.13973],
    "l": 0.5,
    "d": [[-0.00433, 0.00060, -0.04559], [0.00002, -0.27761, 0.05493], [0.00077, 0.27761, 0.05493]],
    "I_L": 2.645e-6 * np.eye(3),
    "I_1": 1e-6 * np.array([[3697.66749, 0.36342, -9.51029], [0.36342, 840.10403, 0.61804], [-9.51029, 0.61804, 3865.05354]]),
    "I_2": 1e-6 * np.array([[441.68245, 0, 0], [0, 441.67985, -1.07006], [0, -1.07006, 0.64418]]),
    "I_3": 1e-6 * np.array([[441.68245, 0, 0], [0, 441.67985, 1.07006], [0, 1.07006, 0.64418]]),
    "beta": np.deg2rad(5.0),
}


def Rx(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def Ry(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def Rz(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def uav_bodies(state, par=TABLE_5_1):
    """The UAV alone (Appendix A, 16 states): q = [x y z phi theta psi alpha_R alpha_L] with (x, y, z) the
    geometric centre: (mass, inertia, centre, velocity, R, omega_body) of the main body and the thrusters."""
    q, qd = np.asarray(state[:8]), np.asarray(state[8:])
    (phi, th, psi), aR, aL = q[3:6], q[6], q[7]
    R_B = Rz(psi) @ Ry(th) @ Rx(phi)
    R_C2B, R_C3B = Rx(-par["beta"]) @ Ry(aR), Rx(par["beta"]) @ Ry(aL)
    W_eta = np.array([[1, 0, -np.sin(th)], [0, np.cos(phi), np.sin(phi) * np.cos(th)], [0, -np.sin(phi), np.cos(phi) * np.cos(th)]])
    w_B = W_eta @ qd[3:6]
    w_2 = R_C2B.T @ w_B + np.array([0, 1, 0]) * qd[6]
    w_3 = R_C3B.T @ w_B + np.array([0, 1, 0]) * qd[7]
    out = []
    for i, (I, R, w) in enumerate(((par["I_1"], R_B, w_B), (par["I_2"], R_B @ R_C2B, w_2), (par["I_3"], R_B @ R_C3B, w_3))):
        d = np.asarray(par["d"][i])
        out.append((par["m"][i + 1], I, q[:3] + R_B @ d, qd[:3] + R_B @ np.cross(w_B, d), R, w))
    return out


def bodies(state, par=TABLE_5_1):
    """(mass, inertia, centre, velocity, R, omega_body) of load, main body, right and left thruster
    (of the UAV alone for a 16-entry state)."""
    if len(state) == 16:
        return uav_bodies(state, par)
    q, qd = np.asarray(state[:10]), np.asarray(state[10:])
    xi, (phi, th, psi), (g1, g2), aR, aL = q[:3], q[3:6], q[6:8], q[8], q[9]
    R_L = Rz(psi) @ Ry(th) @ Rx(phi)
    R_BL = Rx(-g1) @ Ry(-g2)
    R_B = R_L @ R_BL
    R_C2B, R_C3B = Rx(-par["beta"]) @ Ry(aR), Rx(par["beta"]) @ Ry(aL)
    W_eta = np.array([[1, 0, -np.sin(th)], [0, np.cos(phi), np.sin(phi) * np.cos(th)], [0, -np.sin(phi), np.cos(phi) * np.cos(th)]])
    Q = np.array([[-np.cos(g2), 0], [0, -1], [np.sin(g2), 0]])
    w_L = W_eta @ qd[3:6]
    w_B = R_BL.T @ w_L + Q @ qd[6:8]
    w_2 = R_C2B.T @ w_B + np.array([0, 1, 0]) * qd[8]
    w_3 = R_C3B.T @ w_B + np.array([0, 1, 0]) * qd[9]
    rod = np.array([0, 0, par["l"]])
    o_B = xi + R_L @ rod
    v_B = qd[:3] + R_L @ np.cross(w_L, rod)
    out = [(par["m"][0], par["I_L"], xi, qd[:3], R_L, w_L)]
    for i, (I, R, w) in enumerate(((par["I_1"], R_B, w_B), (par["I_2"], R_B @ R_C2B, w_2), (par["I_3"], R_B @ R_C3B, w_3))):
        d = np.asarray(par["d"][i])
        out.append((par["m"][i + 1], I, o_B + R_B @ d, v_B + R_B @ np.cross(w_B, d), R, w))
    return out


def energy(state, g=9.81):
    """Kinetic + potential energy."""
    return sum(0.5 * m * v @ v + 0.5 * w @ I @ w + m * g * c[2] for m, I, c, v, R, w in bodies(state))


def linear_momentum(state):
    return sum(m * v for m, I, c, v, R, w in bodies(state))


def angular_momentum(state):
    """About the inertial origin, in I."""
    return sum(np.cross(c, m * v) + R @ I @ w for m, I, c, v, R, w in bodies(state))


def external_force(state, f_R, f_L, d, g=9.81):
    """Thrusts along each thruster's z axis + all weights + the disturbance (on the load, or the UAV alone), in I."""
    b = bodies(state)
    weight = -g * sum(m for m, *_ in b) * np.array([0, 0, 1.0])
    return f_R * b[-2][4][:, 2] + f_L * b[-1][4][:, 2] + weight + np.asarray(d)


def zse_measurement(state, par=TABLE_5_1):
    """(4.22) from the thesis's formulas: xi_B (4.16), eta_B (4.17)-(4.19), omega_IB^B (4.20), d_BL^B (4.21), servos."""
    q, qd = np.asarray(state[:10]), np.asarray(state[10:])
    xi, (phi, th, psi), (g1, g2) = q[:3], q[3:6], q[6:8]
    R_L = Rz(psi) @ Ry(th) @ Rx(phi)
    R_BL = Rx(-g1) @ Ry(-g2)
    R = R_L @ R_BL
    d_B_L = np.array([0, 0, par["l"]])
    W_eta = np.array([[1, 0, -np.sin(th)], [0, np.cos(phi), np.sin(phi) * np.cos(th)], [0, -np.sin(phi), np.cos(phi) * np.cos(th)]])
    Q = np.array([[-np.cos(g2), 0], [0, -1], [np.sin(g2), 0]])
    eta_B = [np.arctan2(R[2, 1], R[2, 2]), np.arcsin(-R[2, 0]), np.arctan2(R[1, 0], R[0, 0])]
    omega = R_BL.T @ W_eta @ qd[3:6] + Q @ qd[6:8]
    return np.concatenate([xi + R_L @ d_B_L, eta_B, omega, -R_BL.T @ d_B_L, q[8:10], qd[8:10]])

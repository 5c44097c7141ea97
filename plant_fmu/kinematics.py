"""Kinematics of the tilt-rotor UAV's three bodies, with the suspended load from its perspective
(thesis Sec. 2.2) or alone (Appendix A), in CasADi SX.

Positions and orientations only; velocities come from differentiating these, so the
thesis's hand-derived W_eta, Q and Jacobians are never transcribed. The UAV's bodies (main
body and the two thruster groups) are written once, in uav_bodies(), for both vehicles.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca

from . import parameters as P


def rot_x(a, c=None, s=None):
    """Rotation about x by a (or by the angle whose cosine and sine are c and s)."""
    c, s = (ca.cos(a), ca.sin(a)) if c is None else (c, s)
    return ca.vertcat(ca.horzcat(1, 0, 0), ca.horzcat(0, c, -s), ca.horzcat(0, s, c))


def rot_y(a, c=None, s=None):
    c, s = (ca.cos(a), ca.sin(a)) if c is None else (c, s)
    return ca.vertcat(ca.horzcat(c, 0, s), ca.horzcat(0, 1, 0), ca.horzcat(-s, 0, c))


def rot_z(a, c=None, s=None):
    c, s = (ca.cos(a), ca.sin(a)) if c is None else (c, s)
    return ca.vertcat(ca.horzcat(c, -s, 0), ca.horzcat(s, c, 0), ca.horzcat(0, 0, 1))


def vex(S):
    """Inverse of the skew-symmetric map S(.)."""
    return ca.vertcat(S[2, 1], S[0, 2], S[1, 0])


ROTATIONS = {"x": rot_x, "y": rot_y, "z": rot_z}
AXES = {"x": ca.DM([1, 0, 0]), "y": ca.DM([0, 1, 0]), "z": ca.DM([0, 0, 1])}


@dataclass
class Turn:
    """One elementary rotation of a chain: about a body axis by sign * angle, the angle q[index] (index None: a
    constant angle). A negative turn is cos(angle) and -sin(angle): one sine and cosine per angle, not two."""

    axis: str
    angle: ca.SX
    index: int | None = None
    sign: float = 1.0

    def rotation(self) -> ca.SX:
        return ROTATIONS[self.axis](None, ca.cos(self.angle), self.sign * ca.sin(self.angle))


def chain(turns: list[Turn]) -> ca.SX:
    """The rotation R_1 R_2 ... R_n of a chain of turns."""
    R = turns[0].rotation()
    for t in turns[1:]:
        R = R @ t.rotation()
    return R


def chain_rates(turns: list[Turn], qd: ca.SX) -> tuple[ca.SX, ca.SX]:
    """Angular velocity of a chain's last frame in that frame, vex(R^T dR/dt) by composition (thesis 2.5):
    omega_i = R_i^T omega_(i-1) + a_i theta_dot_i, the rate of one turn about its own axis a_i being exact;
    and its rate of change with q_dd = 0 (d omega/dq q_dot, as jtimes would give it):
    (R_i^T omega_(i-1))' = R_i^T omega_dot_(i-1) + (R_i^T omega_(i-1)) x a_i theta_dot_i."""
    w, w_dot = ca.SX.zeros(3), ca.SX.zeros(3)
    for t in turns:
        R = t.rotation()
        w, w_dot = R.T @ w, R.T @ w_dot
        if t.index is not None:
            rate = AXES[t.axis] * (t.sign * qd[t.index])
            w_dot += ca.cross(w, rate)
            w += rate
    return w, w_dot


def chain_rate(turns: list[Turn], qd: ca.SX) -> ca.SX:
    """The angular velocity of chain_rates alone."""
    return chain_rates(turns, qd)[0]


@dataclass
class Body:
    """A rigid body: mass, inertia in its own frame, centre position and rotation in I."""

    name: str
    mass: ca.SX
    inertia: ca.SX
    centre: ca.SX
    rotation: ca.SX


@dataclass
class Kinematics:
    """Symbolic configuration of the system for generalized coordinates q and parameters p.
    bodies: [load, main, right, left] with the load, [main, right, left] without."""

    q: ca.SX
    p: ca.SX
    R_L: ca.SX | None  # load orientation in I (None: the UAV alone)
    R_B_L: ca.SX | None  # UAV frame relative to the rod (load frame)
    R_C_B: list[ca.SX]  # thruster frames relative to B (right, left)
    R_B: ca.SX  # UAV geometric-centre frame in I
    o_B: ca.SX  # UAV geometric centre in I
    bodies: list[Body]
    offsets: list[ca.SX]  # the UAV bodies' centres in B (d_C1, d_C2, d_C3: constant), in the order of bodies[-3:]
    turns_B: list[Turn]  # R_B as a chain (R_L's turns then R_B^L's with the load)
    turns_C: list[list[Turn]]  # R_C^B (right, left) as chains


def param(p: ca.SX, name: str):
    return p[P.index(name)]


def inertia(p: ca.SX, prefix: str) -> ca.SX:
    g = lambda k: param(p, f"{prefix}_{k}")  # noqa: E731
    return ca.vertcat(
        ca.horzcat(g("xx"), g("xy"), g("xz")),
        ca.horzcat(g("xy"), g("yy"), g("yz")),
        ca.horzcat(g("xz"), g("yz"), g("zz")),
    )


def vector(p: ca.SX, prefix: str) -> ca.SX:
    return ca.vertcat(*(param(p, f"{prefix}_{a}") for a in "xyz"))


UAV_OFFSETS = ("d_C1", "d_C2", "d_C3")  # main body, right and left thruster groups


def uav_bodies(p: ca.SX, o_B: ca.SX, R_B: ca.SX, a_R: ca.SX, a_L: ca.SX) -> tuple[list[Body], list[ca.SX]]:
    """The UAV's main body and thruster groups for its geometric centre o_B and frame R_B (Sec. 2.2),
    and the thruster frames relative to B: R_C2^B = Rx(-beta) Ry(alpha_R), R_C3^B = Rx(beta) Ry(alpha_L)."""
    R_C2_B, R_C3_B = (chain(t) for t in thruster_turns(p, a_R, a_L))
    bodies = [
        Body("main", param(p, "m_1"), inertia(p, "I_1"), o_B + R_B @ vector(p, "d_C1"), R_B),
        Body("right", param(p, "m_2"), inertia(p, "I_2"), o_B + R_B @ vector(p, "d_C2"), R_B @ R_C2_B),
        Body("left", param(p, "m_3"), inertia(p, "I_3"), o_B + R_B @ vector(p, "d_C3"), R_B @ R_C3_B),
    ]
    return bodies, [R_C2_B, R_C3_B]


def thruster_turns(p: ca.SX, a_R: ca.SX, a_L: ca.SX, n: int = 0) -> list[list[Turn]]:
    """R_C2^B = Rx(-beta) Ry(alpha_R), R_C3^B = Rx(beta) Ry(alpha_L), alpha_R and alpha_L being q[n-2], q[n-1]."""
    beta = param(p, "beta")
    return [[Turn("x", beta, None, -1.0), Turn("y", a_R, n - 2)], [Turn("x", beta), Turn("y", a_L, n - 1)]]


def build(q: ca.SX, p: ca.SX) -> Kinematics:
    """Forward kinematics (2.22)-(2.23) with R_L = Rz Ry Rx and R_B^L = Rx(-g1) Ry(-g2)."""
    xi = q[0:3]
    phi, theta, psi, g1, g2, a_R, a_L = (q[i] for i in range(3, 10))
    turns_L = [Turn("z", psi, 5), Turn("y", theta, 4), Turn("x", phi, 3)]
    turns_BL = [Turn("x", g1, 6, -1.0), Turn("y", g2, 7, -1.0)]
    R_L, R_B_L = chain(turns_L), chain(turns_BL)
    R_B = R_L @ R_B_L
    o_B = xi + R_L @ ca.vertcat(0, 0, param(p, "l"))
    uav, R_C_B = uav_bodies(p, o_B, R_B, a_R, a_L)
    load = Body("load", param(p, "m_L"), inertia(p, "I_L"), xi, R_L)
    return Kinematics(q, p, R_L, R_B_L, R_C_B, R_B, o_B, [load, *uav], [vector(p, d) for d in UAV_OFFSETS],
                      turns_L + turns_BL, thruster_turns(p, a_R, a_L, q.numel()))


def build_uav(q: ca.SX, p: ca.SX) -> Kinematics:
    """The UAV alone (Appendix A): q = [x y z phi theta psi alpha_R alpha_L], (x, y, z) its geometric
    centre and R_B = Rz(psi) Ry(theta) Rx(phi)."""
    phi, theta, psi, a_R, a_L = (q[i] for i in range(3, 8))
    turns_B = [Turn("z", psi, 5), Turn("y", theta, 4), Turn("x", phi, 3)]
    R_B = chain(turns_B)
    o_B = q[0:3]
    uav, R_C_B = uav_bodies(p, o_B, R_B, a_R, a_L)
    return Kinematics(q, p, None, None, R_C_B, R_B, o_B, uav, [vector(p, d) for d in UAV_OFFSETS], turns_B,
                      thruster_turns(p, a_R, a_L, q.numel()))


def time_derivative(expr: ca.SX, q: ca.SX, qd: ca.SX) -> ca.SX:
    """d/dt of an expression of q along q_dot (forward-mode directional derivative)."""
    flat = ca.reshape(expr, -1, 1)
    return ca.reshape(ca.jtimes(flat, q, qd), expr.size1(), expr.size2())


def body_angular_velocity(R: ca.SX, q: ca.SX, qd: ca.SX) -> ca.SX:
    """Angular velocity in the body frame, vex(R^T dR/dt) (thesis 2.4)."""
    return vex(R.T @ time_derivative(R, q, qd))


def frame_velocity(k: Kinematics, qd: ca.SX) -> tuple[ca.SX, ca.SX, list[ca.SX]]:
    """Velocity of o_B in I, angular velocity of B in B, and those of the load's frame before them ([w_L], or []).

    omega of a child frame = R_rel^T omega_parent + vex(R_rel^T dR_rel/dt) (thesis 2.5),
    with only the small relative rotations differentiated.
    """
    w_B = chain_rate(k.turns_B, qd)
    if k.R_L is not None:  # from the load: the UAV's frame moves with the rod
        w_L = chain_rate(k.turns_B[:3], qd)
        return qd[0:3] + k.R_L @ ca.cross(w_L, ca.vertcat(0, 0, param(k.p, "l"))), w_B, [w_L]
    return qd[0:3], w_B, []  # the UAV alone: q's first three entries are o_B


def frame_accelerations(k: Kinematics, qd: ca.SX) -> tuple[ca.SX, ca.SX, list[ca.SX], list[ca.SX]]:
    """The rates of change with q_dd = 0 (d/dq of the velocity along q_dot) of frame_velocity's three and of the
    thrusters' angular velocities: o_B's acceleration in I (o_B = xi + R_L l e_z: R_L (w_L x (w_L x l e_z) +
    w_L' x l e_z)), B's angular one, [the load's], [right's, left's]."""
    _, w_B_dot = chain_rates(k.turns_B, qd)
    w_C_dot = [chain_rates(k.turns_B + turns, qd)[1] for turns in k.turns_C]
    if k.R_L is None:
        return ca.SX.zeros(3), w_B_dot, [], w_C_dot
    w_L, w_L_dot = chain_rates(k.turns_B[:3], qd)
    rod = ca.vertcat(0, 0, param(k.p, "l"))
    return k.R_L @ (ca.cross(w_L, ca.cross(w_L, rod)) + ca.cross(w_L_dot, rod)), w_B_dot, [w_L_dot], w_C_dot


def body_velocities(k: Kinematics, qd: ca.SX) -> tuple[list[ca.SX], list[ca.SX]]:
    """Centre velocities in I and angular velocities in each body's frame, by composition from B's (frame_velocity)."""
    v_B, w_B, w_L = frame_velocity(k, qd)
    velocities = [qd[0:3]] if w_L else []
    w_C = [chain_rate(k.turns_B + turns, qd) for turns in k.turns_C]
    velocities += [v_B + k.R_B @ ca.cross(w_B, offset) for offset in k.offsets]
    return velocities, [*w_L, w_B, w_C[0], w_C[1]]


def euler_zyx(R: ca.SX) -> ca.SX:
    """Roll, pitch, yaw of a rotation R = Rz(psi) Ry(theta) Rx(phi) (thesis 4.17-4.19, with atan2)."""
    return ca.vertcat(ca.atan2(R[2, 1], R[2, 2]), ca.asin(-R[2, 0]), ca.atan2(R[1, 0], R[0, 0]))

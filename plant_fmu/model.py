"""Euler-Lagrange model of the tilt-rotor UAV with suspended load (thesis ch. 2), or alone
(Appendix A), in CasADi.

From the kinematics alone CasADi builds K, U, M = d2K/dqd2, the Coriolis/centripetal
term by the Lagrange equations, g = dU/dq, and the generalized forces by virtual power:
the one source of truth for the FMU, the controller design and the estimators.
"""

from __future__ import annotations

from functools import cached_property

import casadi as ca

from . import kinematics as kin
from .vehicles import LOAD, VEHICLES, Vehicle

NQ = 10  # the load plant's sizes (the UAV alone: model("uav").nq, .nx)
NX = 2 * NQ
NU = 4
ND = 3


class PlantModel:
    """Symbolic plant: state x = [q, q_dot], inputs u = [f_R, f_L, tau_R, tau_L], load force d.

    The equations of motion use the projection (Kane / TMT) form of the Euler-Lagrange
    equations, M = sum(J' m J + W' I W) and C qd = sum(J' m Jdot qd + W' (I Wdot qd + w x I w)),
    with the UAV's three bodies summed as one composite about o_B (_composite_terms; docs/plant.md),
    which CasADi evaluates far more cheaply than second derivatives of K; lagrangian_terms()
    builds the same M, C qd, g from K and U directly, as an independent check.
    """

    def __init__(self, vehicle: Vehicle = LOAD) -> None:
        self.vehicle, self.nq, self.nx = vehicle, vehicle.nq, vehicle.nx
        self.q = ca.SX.sym("q", self.nq)
        self.qd = ca.SX.sym("qd", self.nq)
        self.u = ca.SX.sym("u", NU)
        self.d = ca.SX.sym("d", ND)
        self.p = ca.SX.sym("p", len(vehicle.parameters))
        self.x = ca.vertcat(self.q, self.qd)
        with_load = vehicle.name == "load"
        p_full = vehicle.full_parameters(self.p)
        self.kin = (kin.build if with_load else kin.build_uav)(self.q, p_full)
        qd, p = self.qd, p_full

        self.velocities, self.omegas = kin.body_velocities(self.kin, qd)
        g = kin.param(p, "g")
        self.kinetic = sum(
            0.5 * b.mass * ca.dot(v, v) + 0.5 * ca.dot(w, b.inertia @ w)
            for b, v, w in zip(self.kin.bodies, self.velocities, self.omegas)
        )
        self.potential = sum(b.mass * g * b.centre[2] for b in self.kin.bodies)

        self.M, self.coriolis = self._composite_terms()
        self.gravity = self._composite_gravity()

        input_forces = self._input_forces()
        self.L_in = ca.jacobian(input_forces, self.u)
        # the disturbance force acts on the load's centre, or on the UAV's geometric centre (A.1)
        self.L_db = ca.jacobian(ca.jacobian(self.velocities[0] if with_load else qd[0:3], qd).T @ self.d, self.d)
        if with_load:
            mu = kin.param(p, "mu_gamma")
            self.L_fr = ca.diag(ca.vertcat(0, 0, 0, 0, 0, 0, mu, mu, 0, 0))
        else:
            self.L_fr = ca.SX.zeros(self.nq, self.nq)

        forces = input_forces - self.L_fr @ qd + self.L_db @ self.d - self.coriolis - self.gravity
        # M is symmetric positive definite: L D L' with the xi and alpha pivots first (their rows meet only the
        # dense eta-gamma block, so nothing fills in)
        self.qdd = _ldl_solve(self.M, forces, [0, 1, 2, *range(self.nq - 2, self.nq), *range(3, self.nq - 2)])
        self.xdot = ca.vertcat(qd, self.qdd)

    def _composite_terms(self) -> tuple[ca.SX, ca.SX]:
        """M and C qd of the projection form, the UAV's bodies taken as one composite about o_B.

        With v_b = v_o + R_B (w_B x d_b) for the UAV's bodies (d_b constant in B), their translational terms
        need only o_B's and B's Jacobians J_o, W_B and the composite's constants m_U, h = sum m_b d_b,
        D = sum m_b (|d_b|^2 I - d_b d_b'): sum m_b J_b' J_b = m_U J_o' J_o - (J_o' X + X' J_o) + W_B' D W_B
        with X = R_B S(h) W_B; a thruster's frame turns by alpha about its y axis (w_C = R_C' w_B + alpha_dot e_y),
        so its rotational terms are W_B' R_C I_C R_C' W_B and a row and column for alpha. The sums are written once
        per composite, symmetric products once per entry: the same M and C qd in about a third of the operations.
        """
        k, qd, nq = self.kin, self.qd, self.nq
        v_o, w_B, w_L = kin.frame_velocity(k, qd)
        J_o, W_B = ca.jacobian(v_o, qd), ca.jacobian(w_B, qd)
        main, *thrusters = k.bodies[-3:]
        masses = [b.mass for b in k.bodies[-3:]]
        m_U = sum(masses)
        h = sum(m * d for m, d in zip(masses, k.offsets))
        D = sum(m * (ca.dot(d, d) * ca.SX.eye(3) - d @ d.T) for m, d in zip(masses, k.offsets))
        rot = D + main.inertia
        for turns, b in zip(k.turns_C, thrusters):
            rot += _conjugate(turns, b.inertia)  # R_C I_C R_C'
        X = k.R_B @ (_skew(h) @ W_B)
        cross = J_o.T @ X
        M = m_U * _symmetric_product(J_o, J_o) - (cross + cross.T) + _symmetric_product(W_B, rot @ W_B)
        # C qd: the qdd-free accelerations a0_o, al0_B of o_B and B; F and N the composite's force and moment in B
        a0_o, al0_B, al0_L, al0_C = kin.frame_accelerations(k, qd)
        ab = k.R_B.T @ a0_o
        F = m_U * ab + ca.cross(w_B, ca.cross(w_B, h)) + ca.cross(al0_B, h)
        N = ca.cross(h, ab) + ca.cross(w_B, (D + main.inertia) @ w_B) + (D + main.inertia) @ al0_B
        alpha_terms = ca.SX.zeros(nq)
        for i, (R, b, w_C, al0) in enumerate(zip(k.R_C_B, thrusters, self.omegas[-2:], al0_C)):
            joint = nq - 2 + i  # alpha_R, alpha_L: the last two coordinates
            tau = b.inertia @ al0 + ca.cross(w_C, b.inertia @ w_C)
            N += R @ tau
            alpha_terms[joint] = tau[1]
            row = (R @ b.inertia[:, 1]).T @ W_B  # the alpha row: e_y' I_C W_C, less its own I_yy
            e = ca.SX.zeros(nq, nq)
            e[joint, :] = row
            M += e + e.T
            M[joint, joint] += b.inertia[1, 1]
        coriolis = J_o.T @ (k.R_B @ F) + W_B.T @ N + alpha_terms
        if w_L:  # the load: J_L = [I 0], so only its rotation has velocity-product terms
            load, w = k.bodies[0], w_L[0]
            W_L = ca.jacobian(w, qd)
            M += _symmetric_product(W_L, load.inertia @ W_L)
            M[0:3, 0:3] += load.mass * ca.SX.eye(3)
            coriolis += W_L.T @ (load.inertia @ al0_L[0] + ca.cross(w, load.inertia @ w))
        return M, coriolis

    def _composite_gravity(self) -> ca.SX:
        """g = dU/dq by virtual power, as the input forces: the weights m g e_z at the load's centre and at the
        UAV composite's o_B, with the moment of the UAV's h about o_B, W_B' (h x R_B' e_z) g."""
        k, qd = self.kin, self.qd
        g = kin.param(k.p, "g")
        m_U = sum(b.mass for b in k.bodies[-3:])
        h = sum(b.mass * d for b, d in zip(k.bodies[-3:], k.offsets))
        v_o, w_B, w_L = kin.frame_velocity(k, qd)
        e_z = ca.DM([0, 0, 1])
        load = ca.jacobian(qd[0:3], qd).T @ (k.bodies[0].mass * g * e_z) if w_L else 0
        return load + ca.jacobian(v_o, qd).T @ (m_U * g * e_z) + ca.jacobian(w_B, qd).T @ (g * ca.cross(h, k.R_B.T @ e_z))

    def _input_forces(self) -> ca.SX:
        """Generalized forces of thrusts, propeller drag and servo torques (Sec. 2.4.1).

        Each force or torque is mapped by the transpose of its body's Jacobian (2.15)-(2.16), written
        through the composite's J_C' = J_o' + W_B' S(d_C) R_B' and W_C' = W_B' R_C + e_alpha e_y': the
        thrust f R_B R_C e_z at the thruster's centre, the drag torque along its z axis, and the servo
        torque, which acts on the thruster and reacts on the main body, so leaves only tau on alpha.
        """
        k, p, nq = self.kin, self.kin.p, self.nq
        drag = kin.param(p, "k_tau") / kin.param(p, "b")
        a_z = ca.DM([0, 0, 1])
        force, moment, servo = 0, 0, ca.SX.zeros(nq)
        for i, (R, d, f, lam, tau) in enumerate(((k.R_C_B[0], k.offsets[1], self.u[0], "lambda_R", self.u[2]),
                                                 (k.R_C_B[1], k.offsets[2], self.u[1], "lambda_L", self.u[3]))):
            thrust = R @ a_z * f  # in B
            force += thrust
            moment += ca.cross(d, thrust) + R @ a_z * (kin.param(p, lam) * drag * f)
            servo[nq - 2 + i] = tau
        v_o, w_B, _ = kin.frame_velocity(k, self.qd)
        return ca.jacobian(v_o, self.qd).T @ (k.R_B @ force) + ca.jacobian(w_B, self.qd).T @ moment + servo

    def lagrangian_terms(self) -> ca.Function:
        """M, C qd, g = dU/dq straight from K and U by the Lagrange equations (reference for tests)."""
        q, qd = self.q, self.qd
        momentum = ca.gradient(self.kinetic, qd)
        M = ca.jacobian(momentum, qd)
        cqd = ca.jtimes(momentum, q, qd) - ca.gradient(self.kinetic, q)
        return ca.Function("tl_plant_lagrange", [self.x, self.p], [M, cqd, ca.gradient(self.potential, q)])

    # --- numeric functions -------------------------------------------------------------
    @cached_property
    def f_terms(self) -> ca.Function:
        """M, C qd, g, L_in, L_fr, L_db at (x, p): what feedforward (3.18) and checks need."""
        return ca.Function(
            "tl_plant_terms",
            [self.x, self.p],
            [self.M, self.coriolis, self.gravity, self.L_in, self.L_fr, self.L_db],
            ["x", "p"],
            ["M", "Cqd", "g", "L_in", "L_fr", "L_db"],
        )

    @cached_property
    def f_jacobians(self) -> ca.Function:
        """Continuous-time Jacobians A_c, B_c, F_c of phi(x, u, d) at any point."""
        return ca.Function(
            "tl_plant_jac",
            [self.x, self.u, self.d, self.p],
            [ca.jacobian(self.xdot, self.x), ca.jacobian(self.xdot, self.u), ca.jacobian(self.xdot, self.d)],
            ["x", "u", "d", "p"],
            ["A", "B", "F"],
        )

    @cached_property
    def diagnostics(self) -> ca.SX:
        """UAV pose, energies, linear and angular momentum (about the inertial origin)."""
        momentum = sum(b.mass * v for b, v in zip(self.kin.bodies, self.velocities))
        angular = sum(
            ca.cross(b.centre, b.mass * v) + b.rotation @ (b.inertia @ w)
            for b, v, w in zip(self.kin.bodies, self.velocities, self.omegas)
        )
        energy = self.kinetic + self.potential
        return ca.vertcat(
            self.kin.o_B, kin.euler_zyx(self.kin.R_B), self.kinetic, self.potential, energy, momentum, angular
        )




def _skew(v: ca.SX) -> ca.SX:
    """S(v), with S(v) w = v x w."""
    return ca.vertcat(ca.horzcat(0, -v[2], v[1]), ca.horzcat(v[2], 0, -v[0]), ca.horzcat(-v[1], v[0], 0))


def _ldl_solve(M: ca.SX, b: ca.SX, order: list[int]) -> ca.SX:
    """x with M x = b for a symmetric positive definite M, by M = L D L' without pivoting in the given order:
    one division per pivot (its reciprocal, then products: a division costs several products' time), structural
    zeros skipped (CasADi drops products with a zero), E = L D kept so each update is one product per term."""
    n = len(order)
    A = M[order, order]
    L = [[ca.SX(0)] * n for _ in range(n)]
    E = [[ca.SX(0)] * n for _ in range(n)]
    inv = [ca.SX(0)] * n
    for j in range(n):
        d = A[j, j] - sum((L[j][k] * E[j][k] for k in range(j)), ca.SX(0))
        inv[j] = 2 / (d + d)  # = 1 / d exactly; written so, CasADi keeps t * inv (it turns t * (1 / d) into t / d)
        for i in range(j + 1, n):
            t = A[i, j] - sum((L[i][k] * E[j][k] for k in range(j)), ca.SX(0))
            E[i][j] = t
            L[i][j] = t * inv[j]
    y = [ca.SX(0)] * n
    rhs = b[order]
    for i in range(n):
        y[i] = rhs[i] - sum((L[i][k] * y[k] for k in range(i)), ca.SX(0))
    x = [ca.SX(0)] * n
    for i in reversed(range(n)):
        x[i] = y[i] * inv[i] - sum((L[k][i] * x[k] for k in range(i + 1, n)), ca.SX(0))
    out = ca.SX.zeros(n)
    for k, i in enumerate(order):
        out[i] = x[k]
    return out


def _conjugate(turns: list, S: ca.SX) -> ca.SX:
    """R S R' for a symmetric S and R the chain of turns: one elementary turn at a time (each mixes two rows and
    two columns), from the last turn to the first."""
    for t in reversed(turns):
        R = t.rotation()
        S = _symmetric_product(R.T, S @ R.T)
    return S


def _symmetric_product(A: ca.SX, B: ca.SX) -> ca.SX:
    """A' B where it is known to be symmetric: each entry of the upper triangle once (over the columns' common
    nonzeros), mirrored; structural zeros stay zeros."""
    n = A.size2()
    out = ca.SX(n, n)
    cols_a = [A[:, i] for i in range(n)]
    cols_b = [B[:, j] for j in range(n)]
    for i in range(n):
        if cols_a[i].nnz() == 0:
            continue
        for j in range(i, n):
            if cols_b[j].nnz() == 0:
                continue
            value = ca.dot(cols_a[i], cols_b[j])
            if value.nnz() and not value.is_zero():
                out[i, j] = value
                out[j, i] = value
    return out


_MODELS: dict[str, PlantModel] = {}


def model(vehicle: str = "load") -> PlantModel:
    """The symbolic model of "load" (ch. 2) or "uav" (Appendix A), built once per process (about a second)."""
    if vehicle not in _MODELS:
        _MODELS[vehicle] = PlantModel(VEHICLES[vehicle])
    return _MODELS[vehicle]

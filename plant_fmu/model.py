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
        q, qd, p = self.q, self.qd, p_full

        self.velocities, self.omegas = kin.body_velocities(self.kin, qd)
        g = kin.param(p, "g")
        self.kinetic = sum(
            0.5 * b.mass * ca.dot(v, v) + 0.5 * ca.dot(w, b.inertia @ w)
            for b, v, w in zip(self.kin.bodies, self.velocities, self.omegas)
        )
        self.potential = sum(b.mass * g * b.centre[2] for b in self.kin.bodies)

        self.M = 0
        self.coriolis = 0
        for b, v, w in zip(self.kin.bodies, self.velocities, self.omegas):
            J, W = ca.jacobian(v, qd), ca.jacobian(w, qd)
            self.M += b.mass * (J.T @ J) + W.T @ b.inertia @ W
            Iw = b.inertia @ w
            self.coriolis += b.mass * (J.T @ ca.jtimes(v, q, qd))
            self.coriolis += W.T @ (b.inertia @ ca.jtimes(w, q, qd) + ca.cross(w, Iw))
        self.gravity = ca.gradient(self.potential, q)

        self.L_in = ca.jacobian(self._input_forces(), self.u)
        # the disturbance force acts on the load's centre, or on the UAV's geometric centre (A.1)
        self.L_db = ca.jacobian(ca.jacobian(self.velocities[0] if with_load else qd[0:3], qd).T @ self.d, self.d)
        if with_load:
            mu = kin.param(p, "mu_gamma")
            self.L_fr = ca.diag(ca.vertcat(0, 0, 0, 0, 0, 0, mu, mu, 0, 0))
        else:
            self.L_fr = ca.SX.zeros(self.nq, self.nq)

        forces = self.L_in @ self.u - self.L_fr @ qd + self.L_db @ self.d - self.coriolis - self.gravity
        D, LT, perm = ca.ldl(self.M)  # M is symmetric positive definite
        self.qdd = ca.ldl_solve(forces, D, LT, perm)
        self.xdot = ca.vertcat(qd, self.qdd)

    def _input_forces(self) -> ca.SX:
        """Generalized forces of thrusts, propeller drag and servo torques (Sec. 2.4.1).

        Each force or torque is mapped by the transpose of its body's Jacobian
        (2.15)-(2.16); the servo torque acts on the thruster and reacts on the main body.
        """
        p, qd = self.kin.p, self.qd
        main, right, left = self.kin.bodies[-3:]
        v = {b.name: vel for b, vel in zip(self.kin.bodies, self.velocities)}
        w = {b.name: om for b, om in zip(self.kin.bodies, self.omegas)}
        drag = kin.param(p, "k_tau") / kin.param(p, "b")
        a_y = ca.DM([0, 1, 0])
        a_z = ca.DM([0, 0, 1])
        W_main = ca.jacobian(w["main"], qd)
        total = 0
        for body, f, lam, tau in (
            (right, self.u[0], "lambda_R", self.u[2]),
            (left, self.u[1], "lambda_L", self.u[3]),
        ):
            J, W = ca.jacobian(v[body.name], qd), ca.jacobian(w[body.name], qd)
            total += J.T @ (body.rotation @ a_z * f)  # thrust along the thruster's z axis
            total += W.T @ (a_z * (kin.param(p, lam) * drag * f))  # propeller drag torque
            axis_in_B = main.rotation.T @ body.rotation @ a_y  # servo axis expressed in B
            total += W.T @ (a_y * tau) - W_main.T @ (axis_in_B * tau)
        return total

    def lagrangian_terms(self) -> ca.Function:
        """M, C qd, g straight from K and U by the Lagrange equations (reference for tests)."""
        q, qd = self.q, self.qd
        momentum = ca.gradient(self.kinetic, qd)
        M = ca.jacobian(momentum, qd)
        cqd = ca.jtimes(momentum, q, qd) - ca.gradient(self.kinetic, q)
        return ca.Function("tl_plant_lagrange", [self.x, self.p], [M, cqd, self.gravity])

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




_MODELS: dict[str, PlantModel] = {}


def model(vehicle: str = "load") -> PlantModel:
    """The symbolic model of "load" (ch. 2) or "uav" (Appendix A), built once per process (about a second)."""
    if vehicle not in _MODELS:
        _MODELS[vehicle] = PlantModel(VEHICLES[vehicle])
    return _MODELS[vehicle]

"""The plant's model against the thesis's formulas and the design cross-checks."""

from __future__ import annotations

import numpy as np
import pytest
from tiltload.plant_fmu import parameters as P
from tiltload.plant_fmu.linearize import linearize, zoh
from tiltload.plant_fmu.model import model
from tiltload.plant_fmu.trim import hover_trim

rng = np.random.default_rng(7)


def random_state(scale=0.6):
    return rng.normal(scale=scale, size=20)


def test_projection_form_matches_lagrange_equations():
    """M, C qd, g from the fast projection form equal those of d/dt dK/dqd - dK/dq + dU/dq."""
    m, p = model(), P.default_vector()
    lag = m.lagrangian_terms()
    for _ in range(5):
        x = random_state()
        M, Cqd, g, *_ = (np.array(v) for v in m.f_terms(x, p))
        M2, Cqd2, g2 = (np.array(v) for v in lag(x, p))
        np.testing.assert_allclose(M, M2, atol=1e-13)
        np.testing.assert_allclose(Cqd, Cqd2, atol=1e-13)
        np.testing.assert_allclose(g, g2, atol=1e-13)


def test_inertia_matrix_is_symmetric_positive_definite_and_passive():
    m, p = model(), P.default_vector()
    for _ in range(5):
        x = random_state()
        M, Cqd, *_ = (np.array(v) for v in m.f_terms(x, p))
        assert np.allclose(M, M.T, atol=1e-15)
        assert np.linalg.eigvalsh(M)[0] > 0
        # power balance of the Lagrange equations: qd' (Mdot qd - 2 C qd) = 0 (skew symmetry)
        qd = x[10:]
        h = 1e-6
        Mp = np.array(m.f_terms(np.r_[x[:10] + h * qd, qd], p)[0])
        Mm = np.array(m.f_terms(np.r_[x[:10] - h * qd, qd], p)[0])
        Mdot = (Mp - Mm) / (2 * h)
        assert qd @ Mdot @ qd == pytest.approx(2 * qd @ Cqd.ravel(), rel=1e-6, abs=1e-9)


def test_input_and_disturbance_maps_have_the_thesis_structure():
    """(2.44)-(2.45): servo torques act only on their own tilt joints; (2.53): d acts on xi only."""
    m, p = model(), P.default_vector()
    x = random_state()
    _, _, _, L_in, L_fr, L_db = (np.array(v) for v in m.f_terms(x, p))
    np.testing.assert_allclose(L_in[:, 2], np.eye(10)[8], atol=1e-14)
    np.testing.assert_allclose(L_in[:, 3], np.eye(10)[9], atol=1e-14)
    np.testing.assert_allclose(L_db, np.vstack([np.eye(3), np.zeros((7, 3))]), atol=1e-14)
    assert np.allclose(np.diag(L_fr), [0] * 6 + [0.005, 0.005, 0, 0])


def test_hover_trim_matches_the_design_cross_check():
    trim = hover_trim()
    q, u = trim.x[:10], trim.u
    assert trim.residual < 1e-10
    assert abs(q[3]) < 1e-12 and abs(q[4]) < 1e-12  # the load hangs straight
    expected = {6: 1.532e-4, 7: 2.808e-2, 8: 2.821e-2, 9: 2.774e-2}
    for i, value in expected.items():
        assert q[i] == pytest.approx(value, rel=2e-3)
    assert u[0] == pytest.approx(9.987, abs=1e-3) and u[1] == pytest.approx(10.022, abs=1e-3)
    assert np.allclose(u[2:], 0, atol=1e-12)


def test_hover_trim_is_yaw_invariant_and_thrust_carries_the_weight():
    t0, t1 = hover_trim(), hover_trim(psi=0.7, position=(1.0, -2.0, 3.0))
    np.testing.assert_allclose(t1.x[[3, 4, 6, 7, 8, 9]], t0.x[[3, 4, 6, 7, 8, 9]], atol=1e-12)
    np.testing.assert_allclose(t1.u, t0.u, atol=1e-10)
    assert t1.residual < 1e-10


def test_open_loop_eigenvalues_match_the_design_brief():
    trim = hover_trim()
    lin = linearize(trim.x, trim.u, P.default_vector())
    ev = np.linalg.eigvals(lin.A)
    real = np.sort(ev[np.abs(ev.imag) < 1e-9].real)
    assert real[-1] == pytest.approx(4.42, abs=0.01) and real[0] == pytest.approx(-4.42, abs=0.01)
    freqs = np.sort(np.abs(ev[ev.imag > 1e-6].imag))
    assert freqs == pytest.approx([4.4, 4.5, 22.8], abs=0.1)
    fast = ev[np.argmax(np.abs(ev.imag))]
    assert fast.real == pytest.approx(-0.67, abs=0.01)


def test_zoh_matches_the_matrix_exponential_series():
    A = np.array([[0.0, 1.0], [-4.0, -0.4]])
    B = np.array([[0.0], [1.0]])
    Ad, Bd = zoh(A, B, 0.012)
    # B_d = integral_0^T e^{A s} ds B, by a fine midpoint rule
    from scipy.linalg import expm

    s = (np.arange(4000) + 0.5) * 0.012 / 4000
    integral = sum(expm(A * si) for si in s) * 0.012 / 4000
    np.testing.assert_allclose(Ad, expm(A * 0.012), rtol=1e-14)
    np.testing.assert_allclose(Bd, integral @ B, rtol=1e-8)
    with pytest.raises(ValueError):
        zoh(A, B, 0.0)


@pytest.mark.parametrize("name, value", [("m_L", 0.0), ("l", -0.5), ("lambda_R", 0.5), ("I_2_zz", 1.0)])
def test_parameter_validation_names_the_culprit(name, value):
    with pytest.raises(P.ParameterError, match=name.split("_z")[0]):
        P.validate(P.vector_from({name: value}))


def test_accelerations_solve_the_equations_of_motion():
    """q_dd (the model's L D L' in its own pivot order) against numpy's solve of M q_dd = forces, with every input on."""
    import casadi as ca

    m, p = model(), P.default_vector()
    f = ca.Function("f", [m.x, m.u, m.d, m.p], [m.xdot, m.M, m.coriolis, m.gravity, m.L_in, m.L_db, m.L_fr])
    for _ in range(5):
        x, u, d = random_state(), rng.normal(size=4), rng.normal(size=3)
        xdot, M, Cqd, g, L_in, L_db, L_fr = (np.array(v) for v in f(x, u, d, p))
        forces = L_in @ u + L_db @ d - L_fr @ x[10:] - Cqd.ravel() - g.ravel()
        np.testing.assert_allclose(xdot.ravel()[10:], np.linalg.solve(M, forces), rtol=1e-12, atol=1e-12)
        np.testing.assert_array_equal(xdot.ravel()[:10], x[10:])


def test_composed_angular_velocities_equal_the_differentiated_rotations():
    """chain_rates (composition over elementary turns) against vex(R' dR/dt) of the whole chain differentiated by
    CasADi, and its q_dd-free rate against CasADi's directional derivative of that angular velocity along q_dot."""
    import casadi as ca
    from tiltload.plant_fmu import kinematics as kin

    m = model()
    k, q, qd = m.kin, m.q, m.qd
    chains = [k.turns_B[:3], k.turns_B, *(k.turns_B + t for t in k.turns_C)]
    composed = [kin.chain_rates(t, qd) for t in chains]
    differentiated = [kin.body_angular_velocity(kin.chain(t), q, qd) for t in chains]
    f = ca.Function("f", [m.x, m.p], [*(w for w, _ in composed), *(w_dot for _, w_dot in composed), *differentiated,
                                      *(ca.jtimes(w, q, qd) for w in differentiated)])
    for _ in range(5):
        out = [np.array(v).ravel() for v in f(random_state(1.0), P.default_vector())]
        n = len(chains)
        for i in range(n):
            np.testing.assert_allclose(out[i], out[2 * n + i], atol=1e-13)
            np.testing.assert_allclose(out[n + i], out[3 * n + i], atol=1e-12)


def test_a_numeric_full_vector_is_casadis_full_parameters():
    """Vehicle.full_vector (numpy, the feasibility check's) gives CasADi's full_parameters bit for bit, for both vehicles,
    and the vehicle's cached defaults are a new array each call."""
    import casadi as ca
    from tiltload.plant_fmu.vehicles import VEHICLES

    rng = np.random.default_rng(3)
    for vehicle in VEHICLES.values():
        p = vehicle.default_parameters() * rng.uniform(0.5, 1.5, len(vehicle.parameters))
        want = np.array(ca.DM(vehicle.full_parameters(ca.DM(p)))).ravel()
        assert np.array_equal(vehicle.full_vector(p), want) and want.shape == (P.N_PARAMETERS,)
        first = vehicle.default_parameters()
        first[0] = -1.0
        assert vehicle.default_parameters()[0] != -1.0

"""The public design namespace (tl.plant, tl.design: docs/design_api.md) against independent facts: the trim zeroes the
model's derivative and balances the forces of an independent numpy model, the linearization is the finite-difference
Jacobian, the discrete model is expm of the continuous one, a delay shifts the input by whole ticks, the DLQR gain
solves scipy's discrete Riccati equation, the LMI designs' poles lie in their regions, the thesis's values hold."""

from __future__ import annotations

import subprocess
import sys

import casadi as ca
import numpy as np
import pytest
import tiltload as tl
from scipy.linalg import expm, solve_discrete_are
from support.physics_oracle import TABLE_5_1, external_force
from tiltload.plant_fmu.model import model as plant_model

EPS, VARPI = 0.55, 0.99402  # thesis Sec. 5.2: Re(z) > eps, |z| < varpi


def _derivative(vehicle: str = "load"):
    m = plant_model(vehicle)
    f = ca.Function("f", [m.x, m.u, m.d, m.p], [m.xdot])
    return lambda x, u, p, d=(0.0, 0.0, 0.0): np.array(f(x, u, d, p)).ravel()


def _fd_jacobian(fun, at: np.ndarray, h: float = 1e-6) -> np.ndarray:
    cols = []
    for i in range(at.size):
        e = np.zeros(at.size)
        e[i] = h
        cols.append((fun(at + e) - fun(at - e)) / (2 * h))
    return np.array(cols).T


def test_the_parameters_are_table_5_1_and_replace_makes_a_checked_copy():
    p = tl.plant.parameters()
    assert [p[k] for k in ("m_L", "m_1", "m_2", "m_3")] == TABLE_5_1["m"] and p["l"] == TABLE_5_1["l"]
    assert p["beta"] == pytest.approx(TABLE_5_1["beta"]) and p["I_1_xz"] == pytest.approx(TABLE_5_1["I_1"][0, 2])
    assert p.unit("m_L") == "kg" and len(p) == len(list(p)) == p.vector.size
    heavy = p.replace(m_L=0.2)
    assert heavy["m_L"] == 0.2 and p["m_L"] == 0.05 and heavy == tl.plant.parameters(m_L=0.2) and heavy != p
    with pytest.raises(ValueError):
        p.vector[0] = 1.0  # read-only
    assert "m_L" not in tl.plant.parameters("uav") and "m_1" in tl.plant.parameters("uav")


@pytest.mark.parametrize("call, error, words", [
    (lambda: tl.plant.parameters(m_X=1.0), tl.TiltloadError, "has no parameter 'm_X'"),
    (lambda: tl.plant.parameters(m_L=-1.0), tl.TiltloadError, "m_L must be positive"),
    (lambda: tl.plant.parameters(m_L="heavy"), TypeError, "m_L must be a number"),
    (lambda: tl.plant.parameters("boat"), tl.TiltloadError, "unknown vehicle 'boat'"),
    (lambda: tl.plant.trim({"m_L": 0.2}), TypeError, "params must be a tl.plant.Parameters"),
    (lambda: tl.plant.linearize(dt=-0.01), tl.TiltloadError, "dt must be positive"),
    (lambda: tl.plant.linearize(delay_ticks=1), tl.TiltloadError, "delay_ticks needs a discrete model"),
    (lambda: tl.plant.linearize(dt=0.012, delay_ticks=5), tl.TiltloadError, "delay_ticks must be one of 0, 1, 2"),
    (lambda: tl.plant.linearize(dt=0.012, delay_ticks=1.0), TypeError, "delay_ticks must be an int"),
    (lambda: tl.design.dlqr(tl.plant.linearize()), tl.TiltloadError, "the designs are discrete"),
    (lambda: tl.design.dlqr(tl.plant.linearize(dt=0.012)), tl.TiltloadError, "thesis's weights are for the model with the integral"),
    (lambda: tl.design.dlqr(tl.plant.linearize(dt=0.012), np.eye(3), np.eye(4)), tl.TiltloadError, "Omega_chi must be 20x20"),
    (lambda: tl.design.dlqr("A"), TypeError, "model must be a tl.plant.LinearModel"),
    (lambda: tl.design.mixed(delay_ticks=3), tl.TiltloadError, "delay_ticks must be one of"),
])
def test_bad_input_is_a_one_line_error_of_the_right_kind(call, error, words):
    with pytest.raises(error) as raised:
        call()
    assert type(raised.value) is error and words in str(raised.value) and "\n" not in str(raised.value)


@pytest.mark.parametrize("params, psi", [(None, 0.0), (tl.plant.parameters(m_L=0.2, l=0.8), 0.0), (None, 0.7)])
def test_the_trim_zeroes_the_derivative_and_balances_the_forces(params, psi):
    eq = tl.plant.trim(params, psi=psi, position=(1.0, -2.0, 3.0))
    p = eq.parameters
    assert np.abs(_derivative()(eq.x, eq.u, p.vector)).max() < 1e-9
    assert eq.state("psi") == psi and eq.state("z") == 3.0 and not eq.x[10:].any()
    if params is None:  # the independent model (Table 5.1): thrusts and weights cancel
        assert np.abs(external_force(eq.x, eq.u[0], eq.u[1], np.zeros(3))).max() < 1e-9


def test_the_trim_has_the_values_of_the_design_cross_check():
    eq = tl.plant.trim()
    expected = {"gamma_1": 1.532e-4, "gamma_2": 2.808e-2, "alpha_R": 2.821e-2, "alpha_L": 2.774e-2}
    for name, value in expected.items():
        assert eq.state(name) == pytest.approx(value, rel=2e-3), name
    assert eq.u == pytest.approx([9.987, 10.022, 0.0, 0.0], abs=1e-3)


def test_the_uav_alone_trims_too():
    eq = tl.plant.trim(vehicle="uav")
    assert eq.x.size == 16 and np.abs(_derivative("uav")(eq.x, eq.u, eq.parameters.vector)).max() < 1e-9


def test_the_continuous_model_is_the_finite_difference_jacobian():
    eq = tl.plant.trim(tl.plant.parameters(m_L=0.1))
    m = tl.plant.linearize(eq)
    f, p = _derivative(), eq.parameters.vector
    assert m.dt is None and m.A.shape == (20, 20) and m.state_names[:3] == ("x", "y", "z")
    np.testing.assert_allclose(m.A, _fd_jacobian(lambda x: f(x, eq.u, p), eq.x), atol=1e-6 * np.abs(m.A).max())
    np.testing.assert_allclose(m.B, _fd_jacobian(lambda u: f(eq.x, u, p), eq.u), atol=1e-6 * np.abs(m.B).max())
    np.testing.assert_allclose(m.F, _fd_jacobian(lambda d: f(eq.x, eq.u, p, d), np.zeros(3)), atol=1e-6 * np.abs(m.F).max())
    assert np.array_equal(m.C, np.eye(20)) and not m.D.any()


def test_the_open_loop_poles_are_the_design_cross_check_s():
    poles = tl.plant.linearize().poles()
    real = np.sort(poles[np.abs(poles.imag) < 1e-6].real)
    assert real[-1] == pytest.approx(4.42, abs=0.01) and real[0] == pytest.approx(-4.42, abs=0.01)


@pytest.mark.parametrize("integral", [False, True])
def test_the_discrete_model_is_expm_of_the_continuous_one(integral):
    dt = tl.plant.TICK
    c = tl.plant.linearize(integral=integral)
    d = tl.plant.linearize(dt=dt, integral=integral)
    n = c.A.shape[0]
    block = np.zeros((n + 7, n + 7))
    block[:n, :n], block[:n, n:n + 4], block[:n, n + 4:] = c.A, c.B, c.F
    E = expm(block * dt)
    np.testing.assert_allclose(d.A, E[:n, :n], rtol=0, atol=1e-12)
    np.testing.assert_allclose(d.B, E[:n, n:n + 4], rtol=0, atol=1e-12)
    np.testing.assert_allclose(d.F, E[:n, n + 4:], rtol=0, atol=1e-12)
    assert dt == 0.012 and d.dt == dt
    if integral:  # (3.8): the integral of the x error grows by the x error
        assert d.state_names[20:] == ("int_x", "int_y", "int_z", "int_psi") and c.A[20, 0] == 1.0 and not c.A[20, 1:].any()


@pytest.mark.parametrize("ticks", [1, 2])
def test_an_input_delay_of_n_ticks_reaches_the_plant_n_ticks_later(ticks):
    plain = tl.plant.linearize(dt=tl.plant.TICK, integral=True)
    late = tl.plant.linearize(dt=tl.plant.TICK, integral=True, delay_ticks=ticks)
    n = plain.A.shape[0]
    assert late.A.shape == (n + 4 * ticks,) * 2 and late.state_names[-4:] == ("f_R[k-1]", "f_L[k-1]", "tau_R[k-1]", "tau_L[k-1]")
    # a pulse du at tick 0 then nothing: the plant's state stays still for `ticks` ticks, then moves as the undelayed one did
    u = np.array([1.0, -0.5, 0.01, 0.02])
    x = late.B @ u
    for _ in range(ticks - 1):
        assert not x[:n].any()
        x = late.A @ x
    assert not x[:n].any()
    np.testing.assert_allclose((late.A @ x)[:n], plain.B @ u, rtol=0, atol=1e-15)
    assert np.array_equal(late.C[:, :20], np.eye(20)) and not late.C[:, 20:].any()


def test_the_dlqr_gain_solves_the_discrete_riccati_equation():
    lqr = tl.design.dlqr()
    m = lqr.model
    assert m.integral and m.dt == tl.plant.TICK and lqr.K.shape == (4, 24)
    P = solve_discrete_are(m.A, m.B, lqr.Q, lqr.R)
    np.testing.assert_allclose(lqr.K, np.linalg.solve(m.B.T @ P @ m.B + lqr.R, m.B.T @ P @ m.A), rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(np.sort_complex(lqr.poles), np.sort_complex(np.linalg.eigvals(m.A - m.B @ lqr.K)))
    assert lqr.spectral_radius < 1 and lqr.regions is None


def test_the_thesis_s_weights_are_sec_5_2_s():
    Q, R = tl.design.weights()
    u = tl.plant.trim().u
    assert Q.shape == (24, 24) and Q[0, 0] == 20 / 2**2 and Q[5, 5] == pytest.approx(15 / np.pi**2) and Q[10, 10] == 1 / 2**2
    np.testing.assert_allclose(np.diag(R), [750 / (30 - u[0]) ** 2, 750 / (30 - u[1]) ** 2, 5000 / 4, 5000 / 4])
    Q[0, 0] = 99.0  # a copy: the next call gives the thesis's again
    assert tl.design.weights()[0][0, 0] == 5.0


def test_a_dlqr_of_your_own_weights_on_the_plain_model():
    m = tl.plant.linearize(dt=tl.plant.TICK, delay_ticks=1)
    Q, R = np.eye(24), 2 * np.eye(4)
    lqr = tl.design.dlqr(m, Q, R)
    P = solve_discrete_are(m.A, m.B, Q, R)
    np.testing.assert_allclose(lqr.K, np.linalg.solve(m.B.T @ P @ m.B + R, m.B.T @ P @ m.A), rtol=1e-8, atol=1e-10)
    assert lqr.spectral_radius < 1


@pytest.mark.parametrize("kind, ticks", [("mixed", 0), ("mixed", 1), ("mixed", 2), ("hinf", 0)])
def test_the_lmi_designs_have_their_poles_in_the_regions(kind, ticks):
    found = getattr(tl.design, kind)(delay_ticks=ticks)
    m = found.model
    assert found.origin == "shipped" and m.integral and m.delay_ticks == ticks and found.K.shape == (4, 24 + 4 * ticks)
    poles = np.linalg.eigvals(m.A - m.B @ found.K)  # on the public model, not the design's own copy
    assert poles.real.min() > EPS and np.abs(poles).max() < VARPI and found.regions == (EPS, VARPI)
    Q, R = tl.design.weights(m)
    np.testing.assert_allclose(found.Q, Q) and np.testing.assert_allclose(found.R, R)
    if kind == "hinf":
        assert found.gamma < 17.4617  # thesis Sec. 5.2: the pure H-infinity design with the regions
    else:
        assert found.gamma == 24.0 and 0 < found.h2_bound < np.inf  # prescribed gamma~ = 24^2


def test_import_tiltload_loads_neither_namespace_until_used():
    code = ("import sys, tiltload as tl; assert 'tiltload.plant' not in sys.modules and 'casadi' not in sys.modules; "
            "tl.plant.TICK; assert 'tiltload.plant' in sys.modules and tl.plant is sys.modules['tiltload.plant']")
    ran = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert ran.returncode == 0, ran.stderr


@pytest.mark.parametrize("ticks", [0, 1, 2])
def test_the_public_dlqr_is_the_gain_the_controller_fmu_embeds(ticks):
    """docs/design_api.md says a gain designed here on the default parameters is the shipped controller's: bit for bit."""
    from tiltload.controller_fmu.design.synthesize import design

    ours = tl.design.dlqr(tl.plant.linearize(dt=tl.plant.TICK, integral=True, delay_ticks=ticks))
    embedded = design("dlqr", tl.plant.TICK, loop_delay=ticks)
    assert np.array_equal(ours.K, embedded.K) and np.array_equal(ours.model.A, embedded.A)

"""The plant FMU: hover, saturation, physics invariants (energy, momenta, their rates), errors, stuck servos, and
the C equal to the CasADi model evaluated by CasADi."""

from __future__ import annotations

import numpy as np
import pytest
from fmpy import simulate_fmu
from fmpy.fmi1 import FMICallException
from support import TUMBLE, T
from support import physics_oracle as ref
from support.fmi2_session import session
from tiltload.plant_fmu import codegen
from tiltload.plant_fmu import parameters as P
from tiltload.plant_fmu.interface import STATE_NAMES

STATES = ["x", "y", "z", "phi", "theta", "psi", "gamma_1", "gamma_2", "alpha_R", "alpha_L"]
STATES += [f"{s}_dot" for s in STATES]


def test_default_simulation_hovers(plant_fmu):
    res = simulate_fmu(str(plant_fmu), stop_time=3.0)
    assert res["time"][-1] == pytest.approx(3.0)
    drift = max(np.max(np.abs(res[n] - res[n][0])) for n in ("x", "y", "z"))
    assert drift < 1e-6


def test_applied_inputs_are_saturated(plant_fmu):
    with session(plant_fmu) as s:
        s.start()
        s.set(f_R=50.0, f_L=-3.0, tau_R=-5.0, tau_L=0.5)
        s.fmu.doStep(0.0, 0.012)
        assert s.get("f_R_applied", "f_L_applied", "tau_R_applied", "tau_L_applied").tolist() == [30.0, 0.0, -2.0, 0.5]


def _run_free(plant_fmu, params, stop, dt=0.012, inputs=None, record=STATES):
    with session(plant_fmu) as s:
        s.set(**params, **{f"{k}_0": v for k, v in TUMBLE.items()})
        s.set(f_R=0.0, f_L=0.0, tau_R=0.0, tau_L=0.0)
        s.start()
        return s.run(stop, dt, record=record, inputs=inputs)


def test_energy_is_conserved_without_friction_or_inputs(plant_fmu):
    rows = _run_free(plant_fmu, {"mu_gamma": 0.0}, stop=2.0, record=STATES + ["E_total"])
    e_ref = np.array([ref.energy(r[:20]) for r in rows])
    # the FMU's energy output agrees with the independent reimplementation ...
    np.testing.assert_allclose(rows[:, 20], e_ref, rtol=1e-12, atol=1e-12)
    # ... and it is conserved: the scale is the kinetic energy plus |potential|
    scale = np.max(np.abs(e_ref))
    assert np.max(np.abs(e_ref - e_ref[0])) / scale < 1e-7
    assert np.ptp(rows[:, 5]) > 0.1  # it really tumbled


def test_friction_dissipates_energy(plant_fmu):
    rows = _run_free(plant_fmu, {"mu_gamma": 0.05}, stop=1.0)
    e = np.array([ref.energy(r) for r in rows])
    assert np.all(np.diff(e) < 1e-9) and e[-1] < e[0] - 1e-4


def test_momenta_are_conserved_without_gravity(plant_fmu):
    names = STATES + ["p_x", "p_y", "p_z", "L_x", "L_y", "L_z"]
    rows = _run_free(plant_fmu, {"g": 0.0, "mu_gamma": 0.0}, stop=2.0, record=names)
    p = np.array([ref.linear_momentum(r[:20]) for r in rows])
    L = np.array([ref.angular_momentum(r[:20]) for r in rows])
    np.testing.assert_allclose(rows[:, 20:23], p, atol=1e-12)
    np.testing.assert_allclose(rows[:, 23:26], L, atol=1e-12)
    assert np.max(np.abs(p - p[0])) < 1e-9
    assert np.max(np.abs(L - L[0])) < 1e-9
    assert np.linalg.norm(p[0]) > 0.1 and np.linalg.norm(L[0]) > 0.01  # non-trivial momenta


def test_momentum_rate_equals_external_forces(plant_fmu):
    """d p/dt = thrusts + weights + d: integrate the right side over the run (Simpson, 0.5 ms grid).

    The residual falls 16x per halving of the grid (2e-5, 1.4e-6, 8.7e-8 at 2, 1, 0.5 ms):
    it is quadrature and RK4 error, not a model mismatch.
    """
    u = dict(f_R=9.0, f_L=11.5, tau_R=0.01, tau_L=-0.02, d_x=0.1, d_y=-0.05, d_z=0.08)
    dt = 0.0005
    with session(plant_fmu) as s:
        s.set(integrator_step=dt, **{f"{k}_0": v for k, v in TUMBLE.items()})
        s.start()
        s.set(**u)
        rows = s.run(0.3, dt, record=STATES)
    p = np.array([ref.linear_momentum(r) for r in rows])
    F = np.array([ref.external_force(r, u["f_R"], u["f_L"], [u["d_x"], u["d_y"], u["d_z"]]) for r in rows])
    from scipy.integrate import simpson

    impulse = simpson(F, dx=dt, axis=0)
    np.testing.assert_allclose(p[-1] - p[0], impulse, rtol=0, atol=1e-7 * np.max(np.abs(impulse)))
    assert np.max(np.abs(impulse)) > 0.1


def test_two_instances_run_independently(plant_fmu):
    with session(plant_fmu, instance="a") as a, session(plant_fmu, instance="b") as b:
        a.set(x_0=1.0)
        a.start()
        b.start()
        a.run(0.12, 0.012)
        b.run(0.12, 0.012)
        assert a.get("x")[0] == pytest.approx(1.0, abs=1e-6)
        assert b.get("x")[0] == pytest.approx(0.0, abs=1e-6)


@pytest.mark.parametrize(
    "params, needle",
    [
        ({"m_L": -0.05}, "m_L must be positive"),
        ({"m_1": 0.0}, "m_1 must be positive"),
        ({"l": 0.0}, "l must be positive"),
        ({"I_1_xx": -1.0}, "inertia I_1"),
        ({"integrator_step": 0.0}, "integrator_step"),
        ({"f_max": -1.0}, "actuator limits"),
    ],
)
def test_bad_parameters_fail_initialization_with_a_reason(plant_fmu, params, needle):
    with session(plant_fmu) as s:
        s.set(**params)
        with pytest.raises(FMICallException):
            s.start()
        assert any(needle in line for line in s.log), s.log


@pytest.mark.parametrize("name", ["f_R", "d_z", "g", "x_0"])
@pytest.mark.parametrize("value", [float("nan"), float("inf")])
def test_non_finite_value_is_refused_when_set(plant_fmu, name, value):
    """Inputs and parameters: fmi2Error naming the variable, and the stored value is unchanged."""
    with session(plant_fmu) as s:
        if not name.endswith("_0") and name != "g":
            s.start()
        before = s.get(name)
        with pytest.raises(FMICallException) as err:
            s.set(**{name: value})
        assert err.value.status == 3  # fmi2Error
        kind = "parameter" if name in ("g", "x_0") else "input"
        assert any(f"non-finite {kind} {name} = {value}" in line for line in s.log), s.log
        np.testing.assert_array_equal(s.get(name), before)


def test_error_state_refuses_steps_until_reset(plant_fmu):
    with session(plant_fmu) as s:
        s.start()
        with pytest.raises(FMICallException):
            s.set(f_R=float("nan"))
        with pytest.raises(FMICallException):
            s.fmu.doStep(0.0, 0.012)
        assert any("fmi2DoStep is not allowed in error" in line for line in s.log), s.log
        s.fmu.reset()  # back to instantiated, start values restored
        s.fmu.setupExperiment(startTime=0.0)
        s.fmu.enterInitializationMode()
        s.start()
        s.fmu.doStep(0.0, 0.012)
        assert abs(s.get("x")[0]) < 1e-9


def test_substep_that_does_not_divide_the_step_is_refused(plant_fmu):
    with session(plant_fmu) as s:
        s.set(integrator_step=0.005)
        s.start()
        with pytest.raises(FMICallException):
            s.fmu.doStep(0.0, 0.012)
        assert any("not a whole multiple of integrator_step" in line for line in s.log)


def test_diverging_state_stops_the_plant_with_last_state_kept(plant_fmu):
    with session(plant_fmu) as s:
        s.set(alpha_R_dot_0=1e160, gamma_1_dot_0=1e160)
        s.start()
        with pytest.raises(FMICallException):
            s.fmu.doStep(0.0, 0.012)
        assert any("diverged" in line for line in s.log)
        assert np.isfinite(s.get(*STATES)).all()
        with pytest.raises(FMICallException):  # latched: no further steps
            s.fmu.doStep(0.012, 0.012)


def test_a_stuck_servo_holds_its_joint_and_does_no_work(plant_fmu):
    """servo_R_stuck: the right tilt joint stops (its rate is zeroed when it sticks) and stays; the constraint
    torque does no work, so without friction or inputs the energy is still conserved."""
    start = {**TUMBLE, "alpha_R_dot": 0.0}
    with session(plant_fmu) as s:
        s.set(mu_gamma=0.0, **{f"{k}_0": v for k, v in start.items()})
        s.set(f_R=0.0, f_L=0.0, tau_R=0.0, tau_L=0.0)
        s.start()
        s.fmu.setBoolean([s.vr["servo_R_stuck"]], [True])
        rows = s.run(1.0, 0.012, record=STATES + ["E_total"])
    assert np.ptp(rows[:, STATES.index("alpha_R")]) < 1e-12 and np.abs(rows[:, STATES.index("alpha_R_dot")]).max() < 1e-12
    assert np.ptp(rows[:, STATES.index("alpha_L")]) > 0.05  # the other joint moves freely
    e = rows[:, -1]
    assert np.max(np.abs(e - e[0])) / np.max(np.abs(e)) < 1e-7


def test_a_servo_that_sticks_mid_flight_stops_at_once_and_frees_again(plant_fmu):
    with session(plant_fmu) as s:
        s.set(**{f"{k}_0": v * 0.3 for k, v in TUMBLE.items()})
        s.start()
        s.run(0.24, 0.012)
        assert abs(s.get("alpha_R_dot")[0]) > 1e-3
        s.fmu.setBoolean([s.vr["servo_R_stuck"]], [True])
        for k in range(20, 40):
            s.fmu.doStep(k * 0.012, 0.012)
            assert abs(s.get("alpha_R_dot")[0]) < 1e-12
        held = s.get("alpha_R")[0]
        s.fmu.setBoolean([s.vr["servo_R_stuck"]], [False])
        for k in range(40, 50):
            s.fmu.doStep(k * 0.012, 0.012)
        assert abs(s.get("alpha_R")[0] - held) > 1e-6  # released: it moves again










# ---- the C ports against their Python references -------------------------------------------------
def test_plant_equals_the_casadi_model_evaluated_by_casadi(native):
    """Same RK4 on the same model, once as generated C in the FMU, once by CasADi's virtual machine."""
    _, rk4, _ = codegen.functions()
    p = P.default_vector()
    u = np.array([10.5, 9.6, 0.01, -0.02])
    d = np.array([0.1, -0.05, 0.08])
    x = np.array([TUMBLE[n] for n in STATE_NAMES])
    with session(native["TiltloadPlant"]) as s:
        s.set(**{f"{k}_0": v for k, v in TUMBLE.items()})
        s.start()
        s.set(f_R=u[0], f_L=u[1], tau_R=u[2], tau_L=u[3], d_x=d[0], d_y=d[1], d_z=d[2])
        worst = 0.0
        for k in range(40):  # 0.48 s: before this open-loop flight runs away
            s.fmu.doStep(k * T, T)
            for _ in range(3):
                x = np.asarray(rk4(x, u, d, p, T / 3)).ravel()
            worst = max(worst, np.max(np.abs(s.get(*STATE_NAMES) - x)))
    assert worst <= 1e-10, worst
    assert np.ptp(x[:10]) > 0.1

"""Sensor-suite, scenario and controller+estimator FMUs through FMPy (DESIGN §1, §3-§6; thesis Sec. 5.1, Table 5.8)."""

from __future__ import annotations

import numpy as np
import pytest
from fmpy import simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.validation import validate_fmu
from fmu_helpers import Session
from tiltload.plant_fmu.interface import STATE_NAMES
from tiltload.plant_fmu.parameters import default_vector
from tiltload.plant_fmu.trim import hover_trim
from tiltload.sensor_fmu.measurement import pi
from tiltload.sensor_fmu.suite import GROUPS, ZSE_NAMES

TRIM = hover_trim(default_vector())
PI_EQ = pi(TRIM.x, default_vector())
T = 0.012


@pytest.fixture
def session(request):
    opened = []

    def open_(path, instance="fmu"):
        s = Session(path, instance)
        opened.append(s)
        return s
    yield open_
    for s in opened:
        s.close()


@pytest.mark.parametrize("name", ["TiltloadPlant", "TiltloadSensors", "TiltloadScenario", "TiltloadController"])
def test_fmpy_validate_finds_no_problem(pipeline_fmus, name):
    assert validate_fmu(str(pipeline_fmus[name])) == []


def test_default_simulations_are_sensible(pipeline_fmus):
    sensors = simulate_fmu(str(pipeline_fmus["TiltloadSensors"]))
    for g in GROUPS:
        if g.source != "pi":
            continue
        for i in g.indices:
            err = sensors[f"meas_{ZSE_NAMES[i]}"] - PI_EQ[i]
            limit = g.bound if g.pdf == "uniform" else 2 * g.bound  # Gaussian: bound = 3 sigma
            assert np.abs(err).max() <= limit + 1e-12, ZSE_NAMES[i]
    scenario = simulate_fmu(str(pipeline_fmus["TiltloadScenario"]), output_interval=T)
    t = scenario["time"][1:-1] - T  # sample and hold: the value recorded at t was sampled at t - T (last step is short)
    np.testing.assert_allclose(scenario["x_ref"][1:-1], 2 * np.cos(np.pi * t / 20), atol=1e-12)
    np.testing.assert_allclose(scenario["z_ref"][1:-1], 9 - 8 * np.cos(np.pi * t / 20), atol=1e-12)
    assert scenario["x_start"][-1] == 1.7 and scenario["duration"][-1] == 40.0
    controller = simulate_fmu(str(pipeline_fmus["TiltloadController"]))  # trim measurements, hover reference
    for i, n in enumerate(("f_R", "f_L", "tau_R", "tau_L")):
        np.testing.assert_allclose(controller[n], TRIM.u[i], atol=1e-9)


def sensor_run(session, path, steps, seed=1, **params):
    s = session(path, f"sensors{seed}")
    s.set_typed(seed=seed)
    if params:
        s.set(**params)
    s.start()
    names = [f"meas_{n}" for n in ZSE_NAMES] + [f"lkf_{n}" for n in STATE_NAMES[:10]]
    flags = [f"{g.name}_new" for g in GROUPS]
    rows, new = [], []
    for k in range(steps):
        s.fmu.doStep(currentCommunicationPoint=k * T, communicationStepSize=T)
        rows.append(s.get(*names))
        new.append(s.get_bool(*flags))
    return np.array(rows), np.array(new, dtype=bool)


def test_noise_bounds_statistics_and_periods(pipeline_fmus, session):
    rows, new = sensor_run(session, pipeline_fmus["TiltloadSensors"], 10_000)
    flags = {g.name: new[:, i] for i, g in enumerate(GROUPS)}
    k = np.arange(10_000)
    assert np.array_equal(flags["gps"], k % 10 == 0) and np.array_equal(flags["cam_xy"], k % 2 == 0)
    assert flags["baro"].all() and flags["servo_rate"].all()
    for g in GROUPS:
        if g.source != "pi":
            continue
        fresh = flags[g.name]
        for i in g.indices:
            noise = rows[fresh, i] - PI_EQ[i]
            if g.pdf == "uniform":
                assert np.abs(noise).max() <= g.bound  # never beyond the bound
                assert np.abs(noise).max() > 0.95 * g.bound  # and it does use the range
            else:
                sigma, n = g.bound / 3, noise.size
                assert abs(noise.std() / sigma - 1) < 4 / np.sqrt(2 * n), (g.name, noise.std(), sigma)
                assert abs(noise.mean()) < 4 * sigma / np.sqrt(n)
        held = rows[~fresh][:, list(g.indices)]
        if held.size:  # between samples the last sample is held
            prev = rows[np.flatnonzero(~fresh) - 1][:, list(g.indices)]
            assert np.array_equal(held, prev)
    lkf_noise = rows[:, 16:19] - TRIM.x[:3]
    assert abs(lkf_noise.std() / 0.05 - 1) < 0.03  # sigma = 5 cm (3 sigma = 15 cm, Sec. 5.3)
    np.testing.assert_array_equal(rows[:, 19:26], np.tile(TRIM.x[3:10], (10_000, 1)))  # the other q are exact


def test_same_seed_same_stream_other_seed_differs(pipeline_fmus, session):
    a, _ = sensor_run(session, pipeline_fmus["TiltloadSensors"], 200, seed=7)
    b, _ = sensor_run(session, pipeline_fmus["TiltloadSensors"], 200, seed=7)
    c, _ = sensor_run(session, pipeline_fmus["TiltloadSensors"], 200, seed=8)
    assert np.array_equal(a, b) and not np.allclose(a, c)


@pytest.mark.parametrize("trajectory", [1, 2])
def test_scenario_derivatives_match_finite_differences(pipeline_fmus, session, trajectory):
    s = session(pipeline_fmus["TiltloadScenario"], f"scenario{trajectory}")
    s.set_typed(trajectory=trajectory)
    s.start()
    names = ("x_ref", "y_ref", "z_ref", "vx_ref", "vy_ref", "vz_ref", "ax_ref", "ay_ref", "az_ref")
    steps = int(52 / T)
    rows = []
    for k in range(steps):
        s.fmu.doStep(currentCommunicationPoint=k * T, communicationStepSize=T)
        rows.append(s.get(*names))
    r = np.array(rows)
    t = np.arange(steps) * T
    joints = np.array([10, 19, 20, 29, 30, 40]) if trajectory == 2 else np.array([])
    smooth = np.all(np.abs(t[1:-1, None] - joints[None, :]) > 3 * T, axis=1) if joints.size else np.ones(steps - 2, bool)
    dpos = (r[2:, 0:3] - r[:-2, 0:3]) / (2 * T)
    dvel = (r[2:, 3:6] - r[:-2, 3:6]) / (2 * T)
    assert np.abs(dpos - r[1:-1, 3:6])[smooth].max() < 2e-3
    assert np.abs(dvel - r[1:-1, 6:9])[smooth].max() < 2e-3
    start = s.get("x_start", "y_start", "z_start")
    np.testing.assert_allclose(start - r[0, 0:3], [-0.3, 0.3, -0.3] if trajectory == 1 else [0.3, -0.3, 0.0], atol=1e-12)
    d = s.get("d_x", "d_y", "d_z")
    assert np.allclose(d, 0.1, atol=1e-6)  # every gust has fully developed by the end


def test_zse_controller_keeps_the_true_state_inside_its_bounds(pipeline_fmus, session):
    """Plant + sensors + ZSE-mode mixed controller in a test loop (not the master), hover, 10 cm start offset."""
    plant = session(pipeline_fmus["TiltloadPlant"], "plant")
    plant.set(x_0=0.1, y_0=-0.1, z_0=0.1)
    sensors = session(pipeline_fmus["TiltloadSensors"], "sensors")
    ctrl = session(pipeline_fmus["TiltloadController"], "controller")
    ctrl.set_typed(controller="mixed", estimator="zse")
    for s in (plant, sensors, ctrl):
        s.start()
    flags = [f"{g.name}_new" for g in GROUPS if g.source == "pi"]
    meas = [f"meas_{n}" for n in ZSE_NAMES]
    ext = list(STATE_NAMES) + ["d_x", "d_y", "d_z"]
    worst, gps_teeth = -np.inf, []
    for k in range(250):
        t = k * T
        x = plant.get(*STATE_NAMES)
        sensors.set(**dict(zip(STATE_NAMES, x)))
        sensors.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=T)
        ctrl.set(**dict(zip(meas, sensors.get(*meas))))
        ctrl.set_typed(**dict(zip(flags, sensors.get_bool(*flags))))
        ctrl.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=T)
        lo, hi = ctrl.get(*[f"est_{n}_lo" for n in ext]), ctrl.get(*[f"est_{n}_hi" for n in ext])
        truth = np.r_[x, 0.0, 0.0, 0.0]
        worst = max(worst, np.max(np.maximum(lo - truth, truth - hi)))
        gps_teeth.append(hi[0] - lo[0])
        plant.set(**dict(zip(("f_R", "f_L", "tau_R", "tau_L"), ctrl.get("f_R", "f_L", "tau_R", "tau_L"))))
        plant.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=T)
    assert worst <= 0.0, f"true state outside the ZSE bounds by {worst:.3g}"
    x = plant.get("x", "y", "z")
    assert np.all(np.abs(x) < 0.1)  # the loop is closed and stable: back toward the hover point
    widths = np.array(gps_teeth[50:])
    assert np.all(np.diff(widths)[np.arange(50, 249) % 10 == 9] < 0)  # the x bound narrows at every GPS sample


@pytest.mark.parametrize("fmu, typed, reals, needle", [
    ("TiltloadSensors", {}, {"gps_period": -0.12}, "gps_period must be positive"),
    ("TiltloadSensors", {}, {"baro_bound": -1.0}, "baro bound must be non-negative"),
    ("TiltloadSensors", {}, {"cam_xy_period": 0.03}, "cam_xy_period = 0.03 s is not a whole multiple"),
    ("TiltloadSensors", {"imu_att_pdf": "cauchy"}, {}, "imu_att_pdf must be one of"),
    ("TiltloadController", {"controller": "pid"}, {}, "unknown controller 'pid'"),
    ("TiltloadController", {"estimator": "ekf"}, {}, "unknown estimator 'ekf'"),
    ("TiltloadScenario", {"trajectory": 4}, {}, "trajectory must be 0, 1, 2 or 3"),
])
def test_bad_parameters_fail_initialization_naming_them(pipeline_fmus, session, fmu, typed, reals, needle):
    s = session(pipeline_fmus[fmu], "bad")
    if typed:
        s.set_typed(**typed)
    if reals:
        s.set(**reals)
    with pytest.raises(FMICallException) as err:
        s.start()
    assert err.value.status == 3  # fmi2Error, with the reason in the log
    assert any(needle in line for line in s.log), s.log


def test_controller_refuses_a_step_that_is_not_tc(pipeline_fmus, session):
    s = session(pipeline_fmus["TiltloadController"], "ctrl")
    s.start()
    with pytest.raises(FMICallException) as err:
        s.fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=0.01)
    assert err.value.status == 3  # fmi2Error: a step of the wrong size is a host error
    assert any("is not the controller period T_c = 0.012 s" in line for line in s.log)

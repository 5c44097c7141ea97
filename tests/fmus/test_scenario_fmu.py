"""The scenario FMU: the trajectories and gusts equal a hand-derived reference, derivatives match differences."""

from __future__ import annotations

import numpy as np
import pytest
from fmpy import simulate_fmu
from support import T
from support import reference_trajectories as ref_traj
from support.fmu_session import session
from tiltload.plant_fmu.parameters import default_vector
from tiltload.plant_fmu.trim import hover_trim
from tiltload.sensor_fmu.measurement import pi
from tiltload.sensor_fmu.suite import GROUPS, ZSE_NAMES


def test_scenario_equals_the_hand_derived_reference(native):
    names = ("x_ref", "y_ref", "z_ref", "vx_ref", "vy_ref", "vz_ref", "ax_ref", "ay_ref", "az_ref", "d_x", "d_y", "d_z")
    for trajectory in (1, 2):
        with session(native["TiltloadScenario"], instance=f"scenario{trajectory}") as s:
            s.set_typed(trajectory=trajectory)
            s.set(gust_tau=0.3, gust_magnitude=0.2)
            s.start()
            duration = ref_traj.DURATION[trajectory]
            worst = 0.0
            for k in range(int(55 / T)):
                s.fmu.doStep(k * T, T)
                t = k * T  # sample and hold: the outputs of doStep(t) are the values at t
                want = np.r_[ref_traj.reference(trajectory, t).ravel(),
                             [ref_traj.gust(t, f * duration, 0.2, 0.3) for f in (0.25, 0.5, 0.75)]]
                worst = max(worst, np.max(np.abs(s.get(*names) - want)))
            assert worst < 1e-12, (trajectory, worst)


TRIM = hover_trim(default_vector())


PI_EQ = pi(TRIM.x, default_vector())




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


@pytest.mark.parametrize("trajectory", [1, 2])
def test_scenario_derivatives_match_finite_differences(pipeline_fmus, opened, trajectory):
    s = opened(pipeline_fmus["TiltloadScenario"], f"scenario{trajectory}")
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

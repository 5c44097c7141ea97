"""The scenario FMU: the trajectories and gusts equal a hand-derived reference, derivatives match differences."""

from __future__ import annotations

import csv
import math
import subprocess
from pathlib import Path

import numpy as np
import pytest
from fmpy import simulate_fmu
from support import HOSTS, ROOT, T
from support import trajectory_oracle as ref_traj
from support.fmi2_session import session
from tiltload.master.app.loop.inputs import READER
from tiltload.plant_fmu.parameters import default_vector
from tiltload.plant_fmu.trim import hover_trim
from tiltload.scenario_fmu import choice, twin, waypoints, wind
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


# ---- the test bench: waypoints, shapes, wind (docs/test_bench.md) ----------------------------------
REF_NAMES = ("x_ref", "y_ref", "z_ref", "vx_ref", "vy_ref", "vz_ref", "ax_ref", "ay_ref", "az_ref", "psi_ref", "psi_dot_ref")
MISSION = ROOT / "docs" / "examples" / "mission.csv"


def _configured(opened, fmu, parameters: dict, name: str = "scenario"):
    """A scenario FMU session with these parameters (by their declared types), initialized."""
    s = opened(fmu, name)
    types = {v.name: v.type for v in s.md.modelVariables}
    typed = {k: (v if types[k] == "String" else int(v) if types[k] == "Integer" else bool(v)) for k, v in parameters.items()
             if types[k] != "Real"}
    if typed:
        s.set_typed(**typed)
    reals = {k: v for k, v in parameters.items() if types[k] == "Real"}
    if reals:
        s.set(**reals)
    s.start()
    return s


def _sample(s, names, steps: int, h: float) -> np.ndarray:
    rows = []
    for k in range(steps):
        s.fmu.doStep(k * h, h)  # sample and hold: the outputs of doStep(t) are the values at t
        rows.append(s.get(*names))
    return np.array(rows)


def test_the_waypoint_reference_in_c_is_its_python_twin_to_the_bit(native, opened, tmp_path):
    mission = choice.resolve(str(MISSION), read=READER)
    parameters = mission.fmu_parameters(tmp_path)
    s = _configured(opened, native["TiltloadScenario"], parameters)
    steps = int((mission.duration + 2) / T)
    got = _sample(s, REF_NAMES, steps, T)
    expected = twin.evaluate(parameters, np.arange(steps) * T)
    np.testing.assert_array_equal(got, np.c_[expected.p, expected.v, expected.a, expected.psi, expected.psi_dot])
    rows = [r for r in csv.DictReader(line for line in MISSION.read_text().splitlines() if not line.startswith("#"))]
    for row in rows:  # through every waypoint, at its time, with the velocity given there
        k = int(round(float(row["t"]) / T))
        if abs(k * T - float(row["t"])) < 1e-12:
            np.testing.assert_allclose(got[k, [0, 1, 2, 9]], [float(row[a]) for a in ("x", "y", "z", "psi")], atol=1e-12)
            if row["vx"]:
                assert got[k, 3] == pytest.approx(float(row["vx"]), abs=1e-12)
    assert np.all(got[-10:, 3:9] == 0) and s.get("duration")[0] == 36.0  # held at rest after the last waypoint
    np.testing.assert_array_equal(s.get("x_start", "y_start", "z_start"), [0.0, 0.0, 1.0])


def test_minimum_jerk_equals_the_qp_that_cvxpy_solves():
    """The closed form against the problem stated directly: monomial coefficients per segment, the waypoints, continuous
    velocity and acceleration, the ends at rest, one fixed velocity; least integral of jerk squared (Clarabel)."""
    import cvxpy as cp

    rows = [{"t": 0, "x": 0}, {"t": 2, "x": 1}, {"t": 5, "x": -1, "vx": 0.5}, {"t": 6, "x": 0}, {"t": 9, "x": 2}]
    rows = [{**r, "y": 0.0, "z": 0.0} for r in rows]
    ref = waypoints.minimum_jerk(rows)
    t = np.array([r["t"] for r in rows], float)
    c = cp.Variable((len(t) - 1, 6))  # x = sum c_k tau^k on each segment, tau from its start

    def derivative(seg, order, tau):
        coeffs = [math.factorial(k) / math.factorial(k - order) * tau ** (k - order) if k >= order else 0.0 for k in range(6)]
        return c[seg] @ np.array(coeffs)

    cost, constraints = 0, []
    for i in range(len(t) - 1):
        T_ = t[i + 1] - t[i]
        G = np.array([[(a * (a - 1) * (a - 2)) * (b * (b - 1) * (b - 2)) * T_ ** (a + b - 5) / (a + b - 5) if a >= 3 and b >= 3 else 0.0
                       for b in range(6)] for a in range(6)])
        cost += cp.quad_form(c[i], cp.psd_wrap(G))
        constraints += [derivative(i, 0, 0) == rows[i]["x"], derivative(i, 0, T_) == rows[i + 1]["x"]]
        if i:
            constraints += [derivative(i, o, 0) == derivative(i - 1, o, t[i] - t[i - 1]) for o in (1, 2)]
    last = t[-1] - t[-2]
    constraints += [derivative(0, 1, 0) == 0, derivative(0, 2, 0) == 0, derivative(len(t) - 2, 1, last) == 0,
                    derivative(len(t) - 2, 2, last) == 0, derivative(2, 1, 0) == 0.5]
    cp.Problem(cp.Minimize(cost), constraints).solve(solver=cp.CLARABEL)
    times = np.linspace(0, 9, 181)
    seg = np.clip(np.searchsorted(t, times, side="right") - 1, 0, len(t) - 2)
    tau = times - t[seg]
    qp = np.array([sum(c.value[s_, k] * x**k for k in range(6)) for s_, x in zip(seg, tau)])
    np.testing.assert_allclose(ref.evaluate(times)[0][:, 0], qp, atol=1e-6)
    assert ref.v[2, 0] == 0.5 and ref.v[0, 0] == 0 and ref.a[-1, 0] == 0


def test_the_references_velocity_and_acceleration_are_its_derivatives_to_second_order(native, opened, tmp_path):
    """Central differences of the FMU's own samples (a 3 ms step) at spacings 24 and 12 ms: their error against the
    reference's velocity and acceleration falls by 4 when the spacing halves (second order: the reference is smooth
    through every waypoint), and the acceleration never jumps."""
    mission = choice.resolve(str(MISSION), read=READER)
    fine = 0.003
    s = _configured(opened, native["TiltloadScenario"], mission.fmu_parameters(tmp_path))
    r = _sample(s, REF_NAMES, int(35.9 / fine), fine)
    errors = {}
    for stride in (8, 4):  # 24 ms and 12 ms
        d = stride * fine
        k = np.arange(8, r.shape[0] - 8, 8)  # the same times for both spacings
        dpos = (r[k + stride, 0:3] - r[k - stride, 0:3]) / (2 * d)
        dvel = (r[k + stride, 3:6] - r[k - stride, 3:6]) / (2 * d)
        errors[stride] = (np.abs(dpos - r[k, 3:6]).max(), np.abs(dvel - r[k, 6:9]).max())
    for which in (0, 1):
        ratio = errors[8][which] / errors[4][which]
        assert 3.7 < ratio < 4.3, (which, errors)
    assert errors[4][0] < 1e-5 and errors[4][1] < 1e-4
    jerk = np.abs(np.diff(r[:, 6:9], axis=0)).max() / fine
    assert jerk < 1.0  # m/s3: no jump in the acceleration anywhere (a jump of 1 mm/s2 would read 0.33)


def _shape_formula(name: str, p: dict, t: np.ndarray) -> np.ndarray:
    """The shapes' positions written out with numpy (shapes.py writes them in CasADi)."""
    c = np.array([p[f"shape_center_{a}"] for a in "xyz"])
    S = np.array([p[f"shape_size_{a}"] for a in "xyz"])
    th = 2 * np.pi * t / p["shape_period"]
    if name == "lemniscate":
        den = 1 + np.sin(th) ** 2
        return c + S * np.c_[np.cos(th) / den, 2 * np.sqrt(2) * np.sin(th) * np.cos(th) / den, np.sin(th)]
    if name == "lissajous":
        return c + S * np.sin(np.c_[[p[f"shape_ratio_{a}"] * th + p[f"shape_phase_{a}"] for a in "xyz"]].T)
    u = np.clip((t - p["shape_onset"]) / (p["shape_rise"] if name == "step" else p["shape_period"]), 0, 1)
    return c + S * (u**3 * (10 - 15 * u + 6 * u**2) if name == "step" else u)[:, None]


@pytest.mark.parametrize("text", ["lemniscate", "lissajous:size_z=1,ratio_z=3", "step-z:rise=2,size=0.5", "ramp-x"])
def test_shapes_are_their_formulas_with_their_derivatives(native, opened, text):
    shape = choice.resolve(text, read=READER)
    p = dict(shape.parameters)
    name = {5: "lemniscate", 6: "lissajous", 7: "step", 8: "ramp"}[p["trajectory"]]
    s = _configured(opened, native["TiltloadScenario"], p, name)
    n = int(shape.duration / T)
    r = _sample(s, REF_NAMES, n, T)
    t = np.arange(n) * T
    np.testing.assert_allclose(r[:, 0:3], _shape_formula(name, p, t), atol=1e-12)
    corners = [p["shape_onset"], p["shape_onset"] + (p["shape_rise"] if name == "step" else p["shape_period"])]
    smooth = np.all(np.abs(t[1:-1, None] - np.array(corners)[None, :]) > 2 * T, axis=1) if name in ("step", "ramp") else slice(None)
    # (a ramp's velocity and a smoothstep's jerk jump at their ends)
    dpos = (r[2:, 0:3] - r[:-2, 0:3]) / (2 * T)
    dvel = (r[2:, 3:6] - r[:-2, 3:6]) / (2 * T)
    assert np.abs(dpos - r[1:-1, 3:6])[smooth].max() < 2e-3
    assert np.abs(dvel - r[1:-1, 6:9])[smooth].max() < 2e-3
    np.testing.assert_allclose(s.get("x_start", "y_start", "z_start"), r[0, 0:3], atol=1e-15)
    assert s.get("duration")[0] == shape.duration


def _host(tmp_path_factory, fmu: Path) -> tuple[Path, Path, dict, str]:
    """The C host of tests/support/hosts/wind_host.c compiled against the FMU's own headers."""
    from fmpy import extract, read_model_description

    folder = Path(extract(str(fmu), str(tmp_path_factory.mktemp("scenario_unpacked"))))
    host = folder / "wind_host"
    subprocess.run(["cc", "-std=c11", "-O2", "-Wall", "-Wextra", "-Werror", f"-I{folder / 'sources'}", str(HOSTS / "wind_host.c"),
                    "-o", str(host), "-ldl", "-lm"], check=True)
    md = read_model_description(str(fmu))
    return host, folder / "binaries" / "linux64" / "TiltloadScenario.so", {v.name: v.valueReference for v in md.modelVariables}, md.guid


def _host_run(host, stop: float, h: float, reals: dict, integers: dict, outputs) -> np.ndarray:
    exe, binary, vr, guid = host
    args = [str(exe), str(binary), guid, repr(stop), repr(h), *(f"r{vr[k]}={v!r}" for k, v in reals.items()),
            *(f"i{vr[k]}={v}" for k, v in integers.items()), *(f"o{vr[n]}" for n in outputs)]
    out = subprocess.run(args, capture_output=True, check=True, timeout=600).stdout
    return np.frombuffer(out).reshape(-1, len(outputs))


@pytest.fixture(scope="module")
def wind_host(native, tmp_path_factory):
    return _host(tmp_path_factory, native["TiltloadScenario"])


TURBULENCE = ("turbulence_u", "turbulence_v", "turbulence_w")


@pytest.mark.slow
def test_dryden_turbulence_has_the_models_variance_and_correlation(wind_host):
    """Moderate turbulence at 10 m (W20 = 30 kn, V = W20), 60000 s at the 12 ms tick through the C host. The estimators'
    standard errors over this record (Bartlett): variance 1.2 % (u), 1.0 % (v), 0.4 % (w); the 1/e correlation time
    about 2.5 %: the tolerances below (5 %, 10 %) are at least four of them."""
    model = wind.dryden(2, 10.0)
    x = _host_run(wind_host, 60000.0, T, {"dryden_altitude": 10.0}, {"trajectory": 0, "dryden": 2, "seed": 11}, TURBULENCE)
    assert x.shape == (5_000_000, 3) and np.all(np.isfinite(x))
    for c in range(3):
        tau_model = wind.correlation_time(c) * model.time_constants[c]
        lags = int(4 * model.time_constants[c] / T)
        rho = _autocorrelation(x[:, c], lags)
        k = int(np.argmax(rho < np.exp(-1)))
        tau = T * (k - 1 + (rho[k - 1] - np.exp(-1)) / (rho[k - 1] - rho[k]))
        variance = np.mean(x[:, c] ** 2)  # the model's mean is zero
        assert abs(variance / model.sigma[c] ** 2 - 1) < 0.05, (c, variance, model.sigma[c] ** 2)
        assert abs(tau / tau_model - 1) < 0.10, (c, tau, tau_model)
        curve = model.correlation(np.arange(lags) * T)[c] / model.sigma[c] ** 2
        assert np.abs(rho - curve).max() < 0.05, c  # the whole curve, with the v, w shape (1 - xi/2L) e^{-xi/L}


def _autocorrelation(x: np.ndarray, lags: int) -> np.ndarray:
    n = 1 << int(np.ceil(np.log2(x.size + lags)))
    f = np.fft.rfft(x, n)
    acov = np.fft.irfft(f * np.conj(f), n)[:lags] / (x.size - np.arange(lags))
    return acov / acov[0]


def test_the_same_seed_gives_the_same_wind_to_the_bit(native, opened, wind_host):
    settings = {"trajectory": 0, "dryden": 3, "seed": 5, "dryden_altitude": 20.0, "steady_wind_x": 2.0, "steady_wind_y": 1.0}
    runs = [_sample(_configured(opened, native["TiltloadScenario"], settings, f"wind{k}"), TURBULENCE, 2000, T) for k in range(2)]
    other = _sample(_configured(opened, native["TiltloadScenario"], {**settings, "seed": 6}, "wind_other"), TURBULENCE, 2000, T)
    c_host = _host_run(wind_host, 2000 * T, T, {k: v for k, v in settings.items() if isinstance(v, float)},
                       {k: v for k, v in settings.items() if isinstance(v, int)}, TURBULENCE)
    assert runs[0].tobytes() == runs[1].tobytes() == c_host.tobytes()  # FMPy twice and a C host: one wind
    assert np.all(np.abs(runs[0] - other).max(axis=0) > 0.1)
    long = [_host_run(wind_host, 2000.0, T, {"dryden_altitude": 20.0}, {"trajectory": 0, "dryden": 3, "seed": seed}, TURBULENCE)
            for seed in (5, 6)]  # 2000 s: thousands of correlation times
    assert all(abs(np.corrcoef(long[0][:, c], long[1][:, c])[0, 1]) < 0.1 for c in range(3))  # another seed: another wind


def test_the_winds_force_is_the_drag_of_steady_wind_profile_and_turbulence(native, opened):
    settings = {"trajectory": 1, "gusts": False, "dryden": 1, "steady_wind_x": 3.0, "steady_wind_y": -4.0, "steady_wind_z": 0.5,
                "wind_profile_count": 3, "drag_area": 0.01, "air_density": 1.2,
                **{f"wind_profile_{f}_{i}": v for i, row in enumerate([(5, 0, 0, 0), (6, 2, 0, -1), (8, 0, 1, 0)])
                   for f, v in zip("txyz", row)}}
    s = _configured(opened, native["TiltloadScenario"], settings)
    out = _sample(s, ("wind_vx", "wind_vy", "wind_vz", *TURBULENCE, "d_x", "d_y", "d_z"), int(10 / T), T)
    t = np.arange(out.shape[0]) * T
    profile = np.c_[np.interp(t, [5, 6, 8], [0, 2, 0]), np.interp(t, [5, 6, 8], [0, 0, 1]), np.interp(t, [5, 6, 8], [0, -1, 0])]
    along = np.array([3.0, -4.0, 0.0]) / 5.0  # u along the horizontal steady wind, v to its left, w up
    left = np.array([4.0, 3.0, 0.0]) / 5.0
    w = np.array([3.0, -4.0, 0.5]) + profile + out[:, 3:4] * along + out[:, 4:5] * left + out[:, 5:6] * [0, 0, 1]
    np.testing.assert_allclose(out[:, 0:3], w, atol=1e-12)
    np.testing.assert_allclose(out[:, 6:9], 0.5 * 1.2 * 0.01 * np.linalg.norm(w, axis=1)[:, None] * w, atol=1e-12)
    sigma = s.get("dryden_sigma_u", "dryden_sigma_w", "dryden_L_u", "dryden_L_w", "dryden_V")
    model = wind.dryden(1, 10.0, steady=(3.0, -4.0, 0.5))
    np.testing.assert_allclose(sigma, [model.sigma[0], model.sigma[2], model.length[0], model.length[2], model.airspeed], rtol=1e-14)
    assert sigma[4] == pytest.approx(np.sqrt(25.25))  # V: the steady wind's speed


def test_the_standards_intensities_and_scale_lengths():
    """MIL-F-8785C at 1000 ft, where the low-altitude model meets the isotropic one: sigma_u = sigma_v = sigma_w = 0.1 W20,
    L_u = L_v = L_w = 1000 ft; at 20 ft by hand: (0.177 + 0.01646)^-0.4 = 1.92914, L_u = 20 ft / 0.1388."""
    top = wind.dryden(3, 304.8)
    np.testing.assert_allclose(top.sigma, [0.1 * 45 * 0.514444] * 3, rtol=1e-12)
    np.testing.assert_allclose(top.length, [304.8] * 3, rtol=1e-12)
    low = wind.dryden(1, 20 * 0.3048)
    assert low.sigma[0] / low.sigma[2] == pytest.approx(1.92914, abs=1e-5)
    assert low.length[0] / 0.3048 == pytest.approx(20 / 0.19346**1.2, rel=1e-4)
    assert low.airspeed == pytest.approx(15 * 0.514444)  # no steady wind: V = W20

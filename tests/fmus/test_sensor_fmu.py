"""The sensor-suite FMU (Table 5.8): samples equal the Python reference, noise statistics and periods, seeds."""

from __future__ import annotations

import numpy as np
import pytest
from support import TUMBLE, T
from support.fmi2_session import session
from tiltload.plant_fmu import parameters as P
from tiltload.plant_fmu.interface import STATE_NAMES
from tiltload.plant_fmu.parameters import default_vector
from tiltload.plant_fmu.trim import hover_trim
from tiltload.sensor_fmu.fmu_variables import channel_names
from tiltload.sensor_fmu.measurement import pi
from tiltload.sensor_fmu.suite import GROUPS, ZSE_NAMES


def _philox_noise(seed, stream, sample, component, gaussian):
    """numpy's Philox4x64-10 at counter (sample, component, 0, 0), key (seed, stream): the C's draw."""
    g = np.random.Philox(key=np.array([seed, stream], dtype=np.uint64),
                         counter=np.array([sample - 1, component, 0, 0], dtype=np.uint64))  # numpy counts up first
    w = g.random_raw(4)
    unit = lambda b: float(int(b) >> 11) / 2.0**53  # noqa: E731
    if gaussian:
        import math
        return math.sqrt(-2.0 * math.log(unit(w[0]) + 2.0**-53)) * math.cos(6.283185307179586 * unit(w[1]))
    return 2.0 * unit(w[0]) - 1.0


def test_sensor_samples_equal_the_python_reference(native):
    """pi(x) by CasADi in Python plus numpy's Philox draws reproduce every sample of the C suite."""
    p = P.default_vector()
    rng = np.random.default_rng(5)
    with session(native["TiltloadSensors"], instance="sensors") as s:
        s.set_typed(seed=123)
        s.start()
        s.fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=T)  # tick 0 would wrap numpy's counter
        for k in range(1, 41):
            x = np.array([TUMBLE[n] for n in STATE_NAMES]) + 0.05 * rng.standard_normal(20)
            s.set(**dict(zip(STATE_NAMES, x)))
            s.fmu.doStep(currentCommunicationPoint=k * T, communicationStepSize=T)
            y = pi(x, p)
            for gi, g in enumerate(GROUPS):
                fresh = s.get_bool(f"{g.name}_new")[0]
                assert fresh == (k % round(g.period / T) == 0)
                if not fresh:
                    continue
                got = s.get(*channel_names(g))
                for j, idx in enumerate(g.indices):
                    b = g.bounds[j if len(g.bounds) > 1 else 0]
                    gaussian = g.pdf == "gaussian"
                    noise = _philox_noise(123, gi, k, j, gaussian) * (b / 3 if gaussian else b)
                    truth = y[idx] if g.source == "pi" else x[idx]
                    assert got[j] == pytest.approx(truth + noise, abs=1e-12), (g.name, k, j)


TRIM = hover_trim(default_vector())


PI_EQ = pi(TRIM.x, default_vector())




def sensor_run(opened, path, steps, seed=1, **params):
    s = opened(path, f"sensors{seed}")
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


def test_noise_bounds_statistics_and_periods(pipeline_fmus, opened):
    rows, new = sensor_run(opened, pipeline_fmus["TiltloadSensors"], 10_000)
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


def test_same_seed_same_stream_other_seed_differs(pipeline_fmus, opened):
    a, _ = sensor_run(opened, pipeline_fmus["TiltloadSensors"], 200, seed=7)
    b, _ = sensor_run(opened, pipeline_fmus["TiltloadSensors"], 200, seed=7)
    c, _ = sensor_run(opened, pipeline_fmus["TiltloadSensors"], 200, seed=8)
    assert np.array_equal(a, b) and not np.allclose(a, c)


def test_seed_is_tunable_and_a_new_seed_draws_that_seeds_noise_from_then_on(pipeline_fmus, opened):
    """The noise is a function of (seed, group, tick, channel): a seed set between steps (a branch from a snapshot)
    gives, from the next sample on, exactly the samples of a run seeded so from the start; a negative one is refused."""
    path = pipeline_fmus["TiltloadSensors"]
    seed_var = next(v for v in opened(path, "probe").md.modelVariables if v.name == "seed")
    assert (seed_var.causality, seed_var.variability) == ("parameter", "tunable")
    switched, _ = sensor_run(opened, path, 100, seed=3)
    s = opened(path, "switching")
    s.set_typed(seed=3)
    s.start()
    names = [f"meas_{n}" for n in ZSE_NAMES] + [f"lkf_{n}" for n in STATE_NAMES[:10]]
    rows = []
    for k in range(100):
        if k == 50:
            s.fmu.setInteger([s.vr["seed"]], [9])
        s.fmu.doStep(currentCommunicationPoint=k * T, communicationStepSize=T)
        rows.append(s.get(*names))
    rows = np.array(rows)
    nine, _ = sensor_run(opened, path, 100, seed=9)
    np.testing.assert_array_equal(rows[:50], switched[:50])  # before the change: seed 3's
    fresh = [k for k in range(50, 100) if not np.array_equal(rows[k], rows[k - 1])]
    assert fresh, "no new sample after the change"
    np.testing.assert_array_equal(rows[fresh[0]:], nine[fresh[0]:])  # every sample drawn since: seed 9's
    assert not np.array_equal(rows[fresh[0]:], switched[fresh[0]:])
    s.fmu.setInteger([s.vr["seed"]], [-1])
    from fmpy.fmi1 import FMICallException

    with pytest.raises(FMICallException):
        s.fmu.doStep(currentCommunicationPoint=100 * T, communicationStepSize=T)
    assert any("seed must be between 0 and 2147483647, got -1" in line for line in s.log)

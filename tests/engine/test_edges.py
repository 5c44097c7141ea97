"""Signals at a run's edges (docs/master.md, "Signals at a run's edges"; engine/edges.py): every channel has one sample
a period from 0 to the run's end, none twice; a run ends at the stop time asked for (a shorter last step where every
FMU takes one, else the first tick after it, said); `always[a:T]` and `eventually[a:T]` over a run that reached T are
decided, and equal the definition evaluated on the logged samples themselves (and the brute-force oracle on the
trace)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from support.stl_oracle import brute
from tiltload.master.app.loop.thesis import default_system
from tiltload.master.engine import edges
from tiltload.master.engine.log import reader as log_reader
from tiltload.master.engine.requirement.check import build_trace, check_log
from tiltload.master.engine.requirement.files import requirement
from tiltload.master.engine.run import run_system
from tiltload.master.engine.system import Instance, System

T = 0.012


def _columns(log) -> dict:
    columns, state = log_reader.read_columns(log)
    assert state.damage is None and not state.torn
    return {topic[1:]: (np.asarray(t, dtype=float), fields) for topic, (t, fields) in columns.items()}


def _expected_times(end: float, ticks: int, shortened: bool) -> np.ndarray:
    grid = np.arange(ticks + 1) * T
    if shortened:
        grid[-1] = end
    return grid


def assert_one_sample_a_tick(log, instances, end: float, ticks: int, shortened: bool = False) -> dict:
    """Every instance's channel: a sample at 0, T, 2T, ..., the last at the run's end; no time twice."""
    data = _columns(log)
    want = _expected_times(end, ticks, shortened)
    for name in instances:
        t = data[name][0]
        assert len(np.unique(t)) == len(t), f"{name}: a time logged twice"
        np.testing.assert_allclose(t, want, rtol=0, atol=1e-9, err_msg=name)
        assert t[-1] == pytest.approx(end, abs=1e-12), name
    return data


def _window_cases(data: dict, instances, a: float, end: float) -> list[tuple[str, str, float, float]]:
    """For every finite Real signal: (name, its always and eventually requirement texts, the definition's robustness of
    each, computed on the logged samples in [a, end] directly)."""
    cases = []
    for name in instances:
        t, fields = data[name]
        inside = (t >= a - 1e-9) & (t <= end + 1e-9)
        for field, values in fields.items():
            x = np.asarray(values, dtype=float)
            if x.dtype.kind != "f" or not np.all(np.isfinite(x)) or not field.isidentifier():
                continue
            c = float(np.median(x))
            signal = f"{name}.{field}"
            cases.append((f"always[{a:g}:{end:.9g}] ({signal} <= {c!r})", float(np.min(c - x[inside])), signal))
            cases.append((f"eventually[{a:g}:{end:.9g}] ({signal} >= {c!r})", float(np.max(x[inside] - c)), signal))
    return cases


def assert_windows_to_the_end_decided(log, data: dict, instances, a: float, end: float) -> int:
    cases = _window_cases(data, instances, a, end)
    reqs = [requirement(f"r{i}", text) for i, (text, _, _) in enumerate(cases)]
    results = check_log(log, reqs)
    series = {name: data[name] for name in instances}
    for (text, want, signal), req, res in zip(cases, reqs, results):
        assert res.verdict != "INCONCLUSIVE", (text, res.why)
        assert res.robustness == want, text  # the definition on the logged samples, bit for bit
        trace = build_trace(series, [signal])
        assert brute(req.formula, trace, 0) == want, text  # and the oracle on the trace the check built
    return len(cases)


LOOP = ("scenario", "sensors", "controller", "plant")


@pytest.fixture(scope="module")
def loop_runs(fmus, tmp_path_factory):
    """The thesis's loop (ZSE, circle, mixed) for 12 s, 20 s and 8.1 s: the log, the stop plan."""
    out = {}
    folder = tmp_path_factory.mktemp("edges")
    for stop in (12.0, 20.0, 8.1):
        system = default_system(fmus, "zse", 1, "mixed")
        log = folder / f"run_{stop:g}.mcap"
        said = []
        res = run_system(system, stop, log, progress=False, announce=lambda ex, s=stop: said.append(ex.stop_plan(s)))
        assert res.error is None
        out[stop] = (log, said[0], res)
    return out


@pytest.mark.parametrize("stop", [12.0, 20.0, 8.1])
def test_the_loop_logs_every_channel_once_a_tick_to_its_end_and_windows_ending_there_are_decided(loop_runs, stop):
    log, plan, res = loop_runs[stop]
    ticks = math.ceil(stop / T - 1e-9)
    # the controller and the sensors take no other step (canHandleVariableCommunicationStepSize false): 20 s is not a
    # whole number of ticks, so the run ends at the first tick after it, and says so
    assert plan.ticks == ticks and not plan.shortened
    assert (plan.note is None) == (abs(stop / T - round(stop / T)) < 1e-9)
    assert plan.end == pytest.approx(ticks * T, abs=1e-12) and res.sim_time == plan.end
    data = assert_one_sample_a_tick(log, LOOP, plan.end, ticks)
    a = round(stop / 2 / T) * T
    for end in {plan.end, stop}:  # windows ending at the run's end, and at the time asked
        assert assert_windows_to_the_end_decided(log, data, LOOP, a, end) > 100


def test_the_controllers_first_sample_is_its_command_at_zero_not_its_start_value(loop_runs):
    """The issue's drop to 0 N that never happened: one sample at t = 0, the command the step at 0 computed."""
    data = _columns(loop_runs[12.0][0])
    t, fields = data["controller"]
    assert t[0] == 0.0 and t[1] == pytest.approx(T) and fields["f_R"][0] > 5.0


def test_a_stop_time_off_the_tick_ends_with_a_shorter_last_step_where_every_fmu_takes_one(native, tmp_path):
    """The scenario (sampled at its step's start) and the plant (at its step's end), both canHandleVariable-
    CommunicationStepSize (the plant's steps whole multiples of its 4 ms integrator step): 0.248 s at a 12 ms tick is
    20 ticks and a last step of 8 ms; each channel's last sample is at 0.248 s, and windows ending there are decided."""
    system = System(T, [Instance("scenario", native["TiltloadScenario"], timing="sample", parameters={"gusts": False}),
                        Instance("plant", native["TiltloadPlant"])])
    said = []
    res = run_system(system, 0.248, tmp_path / "short.mcap", progress=False, announce=lambda ex: said.append(ex.stop_plan(0.248)))
    assert res.error is None and said[0].shortened and said[0].note is None and said[0].ticks == 21
    assert res.sim_time == 0.248
    data = assert_one_sample_a_tick(tmp_path / "short.mcap", ("scenario", "plant"), 0.248, 21, shortened=True)
    assert assert_windows_to_the_end_decided(tmp_path / "short.mcap", data, ("scenario", "plant"), 0.12, 0.248) > 20
    # the scenario's last sample is its reference at 0.248 s itself, not the one at 0.24 s held
    x = data["scenario"][1]["x_ref"]
    assert x[-1] != x[-2]


def test_the_stop_plan():
    assert edges.stop_plan(12.0, T, {"a": False}) == edges.StopPlan(12.0, 1000, 12.0, False, None)
    assert edges.stop_plan(0.25, 0.1, {"a": True}) == edges.StopPlan(0.25, 3, 0.25, True, None)
    rounded = edges.stop_plan(0.25, 0.1, {"a": True, "b": False})
    assert (rounded.ticks, rounded.end, rounded.shortened) == (3, pytest.approx(0.3), False)
    assert "b cannot take a shorter last step: the run ends at 0.3 s" in rounded.note
    assert edges.stop_plan(8.1, T, {}).ticks == 675  # 8.1 / 0.012 is 674.9999999999999 in floating point


CASES = [(scenario, vehicle, fmi, clocked) for scenario in ("fsi", "lkf", "zse") for vehicle in ("load", "uav")
         for fmi, clocked in ((2, False), (3, False), (3, True)) if (scenario, vehicle) != ("lkf", "uav")]  # no LKF there


@pytest.fixture(scope="module")
def every_fmu_set(fmus, fmi3_fmus):
    from tiltload.master.app.loop.fmus import build_all

    fmi3 = fmi3_fmus["TiltloadPlant"].parent
    build_all(fmus, progress=lambda *_: None, vehicles=("uav",))
    for clocked in (False, True):
        build_all(fmi3, progress=lambda *_: None, vehicles=("load", "uav"), fmi_version=3, clocked=clocked)
    return {2: fmus, 3: fmi3}


@pytest.mark.parametrize("scenario, vehicle, fmi, clocked", CASES)
def test_no_channel_has_two_samples_at_one_time(every_fmu_set, tmp_path, scenario, vehicle, fmi, clocked):
    """Every shipped scenario, vehicle and FMI version (3.0 with clocks too): each channel once a tick, 0 to T."""
    controller = "dlqr" if vehicle == "uav" else "mixed"
    system = default_system(every_fmu_set[fmi], scenario, None, controller, vehicle=vehicle,
                            **({"fmi": 3, "clocked": clocked} if fmi == 3 else {}))
    res = run_system(system, 0.24, tmp_path / "run.mcap", progress=False)
    assert res.error is None
    assert_one_sample_a_tick(tmp_path / "run.mcap", LOOP, 0.24, 20)


def test_an_isolated_fmu_follows_the_same_rule(fmus, tmp_path):
    """The controller in a worker process of its own (stepped through the loop's Python callback): the same samples, the
    same values, as in this process."""
    logs = {}
    for where, isolate in (("here", None), ("worker", lambda fmu, md: "Controller" in fmu.name)):
        res = run_system(default_system(fmus, "zse", 1, "mixed"), 0.24, tmp_path / f"{where}.mcap", progress=False,
                         isolate=isolate)
        assert res.error is None
        logs[where] = assert_one_sample_a_tick(tmp_path / f"{where}.mcap", LOOP, 0.24, 20)
    for name in LOOP:
        for field, values in logs["here"][name][1].items():
            np.testing.assert_array_equal(logs["worker"][name][1][field], values, err_msg=f"{name}.{field}")

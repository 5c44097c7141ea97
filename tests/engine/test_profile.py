"""`tiltload run --profile` (engine/profile.py): the C loop's figures against an independent measurement of the same
FMU's step (FMPy's doStep timed alone from Python, another process-free harness on another clock read), and its parts
against the wall time Python measures around the whole loop."""

from __future__ import annotations

import shutil
import statistics
import tempfile
import time
import zipfile

import numpy as np
import pytest
from tiltload.master.app.cli import main
from tiltload.master.app.loop.thesis import default_system, loop_metrics
from tiltload.master.engine.execution import Execution
from tiltload.master.engine.fmi.model_description import read_fmu
from tiltload.master.engine.profile import BUCKETS, Profiler, bucket_bounds, quantile

AGREEMENT = 3.0  # the loop's median step against the harness's: within this factor either way (both on a shared machine)


def _harness_median(fmu, tick: float, steps: int = 500) -> float:
    """The FMU's doStep timed alone with FMPy (no tiltload code), its median in seconds (the plant, unpowered, falls
    for 6 s: its step's work is its integrator's, whatever the inputs)."""
    from fmpy.fmi2 import FMU2Slave

    md = read_fmu(fmu, "alone")
    unzipped = tempfile.mkdtemp(prefix="tl-profile-")
    try:
        with zipfile.ZipFile(fmu) as z:
            z.extractall(unzipped)
        slave = FMU2Slave(guid=md.guid, unzipDirectory=unzipped, modelIdentifier=md.coSimulation.modelIdentifier,
                          instanceName="alone")
        slave.instantiate()
        slave.setupExperiment(startTime=0.0)
        slave.enterInitializationMode()
        slave.exitInitializationMode()
        times = []
        for k in range(steps):
            started = time.perf_counter_ns()
            slave.doStep(k * tick, tick)
            times.append(time.perf_counter_ns() - started)
        slave.terminate()
        slave.freeInstance()
    finally:
        shutil.rmtree(unzipped, ignore_errors=True)
    return statistics.median(times) * 1e-9


def test_the_histogram_reads_back_what_it_was_given():
    """Times put into buckets as tl_loop.c does (frexp) come back within a bucket's width (6 %), min and max exact."""
    rng = np.random.default_rng(66)
    ns = np.exp(rng.uniform(np.log(50), np.log(5e7), 5000)).astype(np.int64)
    m, e = np.frexp(ns.astype(float))
    histogram = np.bincount(e * 16 + ((m - 0.5) * 32).astype(int), minlength=BUCKETS)
    for q in (0.5, 0.99):
        assert quantile(histogram, q, ns.min(), ns.max()) == pytest.approx(np.quantile(ns, q), rel=0.07)
    for b in (0, 17, 160, 639):
        low, high = bucket_bounds(b)
        assert high > low and (high - low) / low <= 1 / 16 + 1e-12


def test_the_profile_agrees_with_the_fmu_timed_alone_and_its_parts_with_the_wall_time(fmus):
    system = default_system(fmus, "lkf", 1, "mixed")
    ex = Execution(system, [loop_metrics()])
    ex.instantiate()
    try:
        profiler = Profiler(ex)
        started = time.perf_counter()
        profiler.start()
        ex.run(6.0)
        profile = profiler.stop()
        wall = time.perf_counter() - started
    finally:
        ex.close()
    plant = next(f for f in profile.fmus if f.name == "plant")
    assert plant.steps.count == profile.ticks == 500 and profile.tick_times.count == 500
    assert plant.steps.min <= plant.steps.median <= plant.steps.p99 <= plant.steps.max
    alone = _harness_median(fmus / "TiltloadPlant.fmu", system.tick)
    assert 1 / AGREEMENT < plant.steps.median / alone < AGREEMENT, (plant.steps.median, alone)
    # the parts: the ticks measured in C and the observers in Python fill the loop's wall time, less its Python between
    # two calls of the kernel (the master's share holds that remainder)
    assert profile.total <= wall
    measured = profile.tick_times.total + profile.log + profile.observers
    assert 0.5 * profile.total < measured <= profile.total
    assert sum(f.steps.total for f in profile.fmus) <= profile.tick_times.total
    assert sum(profile.shares().values()) == pytest.approx(1.0)
    assert profile.margin()[0] == system.tick  # the controller's period


def test_run_profile_prints_every_fmu_and_the_margin(fmus, tmp_path, capsys):
    code = main(["run", "--stop-time", "1", "--profile", "--fmus", str(fmus), "--out", str(tmp_path), "--quiet", "--no-plots"])
    out = capsys.readouterr().out
    assert code == 0
    table = out[out.index("profile: "):].splitlines()
    for part in ("scenario", "sensors", "controller", "plant", "master", "log", "observers", "tick"):
        assert any(line.split()[0] == part for line in table[2:]), (part, table)
    assert any(line.startswith("real-time margin: the controller's period is 12 ms") for line in table)


def test_run_profile_goes_into_the_report(fmus, tmp_path, capsys):
    page = tmp_path / "run.html"
    assert main(["run", "--stop-time", "1", "--profile", "--report", str(page), "--fmus", str(fmus), "--out", str(tmp_path),
                 "--quiet", "--no-plots"]) == 0
    html = page.read_text()
    assert "Where the ticks&#39; time went (--profile)" in html or "Where the ticks' time went (--profile)" in html
    assert "median µs" in html and "real-time margin" in html

"""Issue 52's cheaper evaluations give what the plain ones give, bit for bit: the feasibility check's Newton steps in C
against plant_fmu.trim.newton (CasADi's virtual machine, numpy's solve), the check's caches against a check without
them, a search's rows on a warm worker (pooled executions, cached verdicts, compiled trims) against each point run
alone the plain way; and the batches' task sizes (docs/throughput.md)."""

from __future__ import annotations

import math
import os
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
TIMING = ("wall_s", "cpu_s", "worker")


def plain(monkeypatch):
    """The check as it was: Python's Newton steps, CasADi's map of the feedforward, numpy's mission, nothing cached."""
    from tiltload.master.app.feasibility import policy, trajectory_check, trim_residual

    for name in ("compiled_newton", "compiled_feedforward", "compiled_mission"):
        monkeypatch.setattr(trim_residual, name, lambda vehicle: None)
    trajectory_check._hover.cache_clear()
    trajectory_check._trim_start.cache_clear()
    trajectory_check._REFERENCES.clear()
    policy._IDENTIFIERS.clear()


@pytest.mark.parametrize("vehicle", ["load", "uav"])
def test_newton_in_c_takes_python_s_steps_to_the_bit(vehicle):
    from tiltload.master.app.feasibility.trim_residual import compiled_newton
    from tiltload.plant_fmu.trim import hover_trim, newton, unknown_coordinates
    from tiltload.plant_fmu.vehicles import VEHICLES

    solve = compiled_newton(vehicle)
    if solve is None:
        pytest.skip("no C compiler")
    p = VEHICLES[vehicle].default_parameters()
    hover = hover_trim(p, vehicle=vehicle)
    start = np.r_[hover.x[unknown_coordinates(vehicle)], hover.u]
    rng = np.random.default_rng(7)
    outcomes = {"converged": 0, "not": 0}
    for _ in range(150):
        z = start + rng.normal(scale=rng.choice([0.01, 0.3, 3.0]), size=start.size)  # near, farther, hopeless
        ref = np.r_[rng.normal(size=4), rng.normal(scale=0.5, size=4), rng.normal(scale=rng.choice([0.5, 20.0]), size=3)]
        q = p * rng.uniform(0.5, 2.0, size=p.size)
        theirs, ours = newton(vehicle, z, ref, q, 1e-9, 20), solve(z, ref, q, 1e-9, 20)
        assert (theirs is None) == (ours is None)
        if theirs is not None:
            assert theirs[0].tobytes() == ours[0].tobytes() and theirs[1:] == ours[1:]
        outcomes["converged" if theirs is not None else "not"] += 1
    assert min(outcomes.values()) > 0, outcomes  # both ways of ending were compared
    for scale in (1.0, 1.3, 0.7):  # the first mass of the vehicle's parameters (the load's or the UAV's)
        q = p.copy()
        q[0] *= scale
        a, b = hover_trim(q, 0.4, vehicle=vehicle, solve=solve), hover_trim(q, 0.4, vehicle=vehicle)
        assert a.x.tobytes() == b.x.tobytes() and a.u.tobytes() == b.u.tobytes()
        assert (a.residual, a.iterations) == (b.residual, b.iterations)


@pytest.mark.parametrize("vehicle", ["load", "uav"])
def test_the_residual_alone_is_the_residual_of_the_residual_and_jacobian_to_the_bit(vehicle):
    """What lets Newton's last evaluation skip the Jacobian (trim_newton.c) without changing a trim."""
    from tiltload.plant_fmu.trim import residual_functions

    full, alone = residual_functions(vehicle)
    rng = np.random.default_rng(2)
    for _ in range(200):
        args = [rng.normal(scale=rng.choice([0.1, 3.0]), size=full.nnz_in(k)) for k in range(3)]
        assert np.array(alone(*args)).tobytes() == np.array(full(*args)[0]).tobytes()


@pytest.mark.parametrize("vehicle", ["load", "uav"])
def test_the_feedforward_along_a_reference_in_c_is_casadi_s_map_to_the_bit(vehicle):
    """The states and accelerations built from the reference's rows in C, and the feedforward in two parts (what the rows
    leave unchanged computed once), against numpy's and CasADi's map of the whole function
    (trajectory_check.feedforward_map, what runs without a compiler), at random rows and a random hover state."""
    from tiltload.master.app.feasibility.trajectory_check import feedforward_map
    from tiltload.master.app.feasibility.trim_residual import compiled_feedforward, feedforward
    from tiltload.plant_fmu.vehicles import VEHICLES

    along = compiled_feedforward(vehicle)
    if along is None:
        pytest.skip("no C compiler")
    f, rng, n = feedforward(vehicle), np.random.default_rng(5), 2000
    hover_x, refs = rng.normal(size=f.size1_in(0)), rng.normal(scale=3.0, size=(n, 11))
    refs[rng.random(size=refs.shape) < 0.3] = 0.0  # at rest, level: zeros where a reference has them (signs of zero)
    refs[rng.random(size=refs.shape) < 0.05] *= -0.0
    p = VEHICLES[vehicle].default_parameters() * rng.uniform(0.8, 1.2, size=f.size1_in(2))
    ours, theirs = along(hover_x, refs, p), feedforward_map(f, hover_x, refs, p)
    assert ours.shape == (n, 4) and ours.tobytes() == theirs.tobytes()
    wide = np.column_stack([refs, rng.normal(size=n)])  # rows read in place, 12 doubles apart (a mission's)
    assert along(hover_x, wide[:, :11], p).tobytes() == ours.tobytes()
    nq = f.size1_in(1)  # and by hand at one row: the state's rates but the load's and psi's are 0
    x = hover_x.copy()
    x[[0, 1, 2, 5]], x[nq:] = refs[7, :4], 0.0
    x[[nq, nq + 1, nq + 2, nq + 5]] = refs[7, 4:8]
    assert np.array(f(x, np.r_[refs[7, 8:11], np.zeros(nq - 3)], p)).ravel().tobytes() == ours[7].tobytes()


def test_a_mission_evaluated_by_the_scenario_fmu_s_c_is_numpy_s_evaluation_to_the_bit():
    from tiltload.master.app.feasibility.trim_residual import compiled_mission
    from tiltload.scenario_fmu.waypoints import minimum_jerk

    mission = compiled_mission("load")
    if mission is None:
        pytest.skip("no C compiler")
    rng = np.random.default_rng(11)
    for _ in range(200):
        n = int(rng.integers(2, 14))
        t = np.cumsum(rng.uniform(0.01, 5.0, size=n)) - rng.uniform(0, 0.01)
        rows = [{"t": float(ti), "x": float(rng.normal()), "y": float(rng.normal()), "z": float(rng.normal(3)),
                 "psi": float(rng.normal(scale=0.3))} for ti in t]
        for row in rows[1:-1]:
            if rng.random() < 0.3:
                row["vx"], row["az"] = float(rng.normal()), float(rng.normal())
        ref = minimum_jerk(rows)
        times = np.r_[np.arange(0.0, t[-1] + 1.0, 0.012), t, t[0] - 0.5]  # before, at every knot, after the end
        theirs, ours = ref.evaluate(times), mission(ref, times)
        for a, b in zip(theirs, (ours[:, 0:4], ours[:, 4:8], ours[:, 8:12])):
            assert a.tobytes() == b.tobytes()


def test_the_check_with_its_caches_and_compiled_trims_says_what_the_plain_check_says(monkeypatch):
    from tiltload.master.app.feasibility.trajectory_check import Limits, check_reference

    rng = np.random.default_rng(3)
    cases = [({"trajectory": int(rng.integers(1, 4))}, {"m_L": float(rng.uniform(0.01, 8)), "l": float(rng.uniform(0.2, 1.5))},
              Limits(f_max=float(rng.uniform(8, 30)), tau_max=float(rng.uniform(0.02, 2)), max_tilt=float(rng.uniform(1, 30))))
             for _ in range(12)]
    cases += [({"trajectory": 2}, {}, Limits()), ({"trajectory": 2}, {}, Limits(f_max=5.0, tau_max=0.001))]  # the same
    # reference under other limits: its cached facts are the limits' own

    def reports():
        return [vars(check_reference(s, 20.0, "load", plant, limits, design=("mixed", 0))) for s, plant, limits in cases]

    ours = reports() + reports()  # the second time from the caches
    theirs = []
    for s, plant, limits in cases:  # each case alone, nothing cached
        plain(monkeypatch)
        theirs.append(vars(check_reference(s, 20.0, "load", plant, limits, design=("mixed", 0))))
    assert ours == theirs + theirs
    assert any(r["problems"] for r in theirs) and any(not r["problems"] for r in theirs)  # refusals and passes compared


def test_the_check_without_its_explanations_finds_the_same_problems_in_the_same_order():
    """What a worker asks (explain=False: no summary, no notes) against the whole check, over plants and limits that
    refuse for the thrusts of the trims and of the feedforward and for the tilt."""
    from tiltload.master.app.feasibility.trajectory_check import Limits, check_reference

    rng = np.random.default_rng(11)
    cases = [({"trajectory": int(rng.integers(1, 4))}, {"m_L": float(rng.uniform(0.01, 8)), "l": float(rng.uniform(0.2, 1.5))},
              Limits(f_max=float(rng.uniform(8, 30)), tau_max=float(rng.uniform(0.02, 2)), max_tilt=float(rng.uniform(1, 30))),
              ("mixed", int(rng.integers(0, 3)))) for _ in range(16)]
    seen = set()
    for scenario, plant, limits, design in cases:
        whole = check_reference(scenario, 20.0, "load", plant, limits, design=design)
        short = check_reference(scenario, 20.0, "load", plant, limits, design=design, explain=False)
        assert short.problems == whole.problems and short.notes == [] and short.summary == ""
        seen.update(p.split(" would need")[0] for p in whole.problems)
    assert {"f_R", "the trim's f_R", "phi", "theta"} <= seen, seen  # the kinds of refusal a case meets compared


def test_a_reference_checked_in_chunks_says_what_it_says_in_one(monkeypatch):
    """A span longer than CHUNK ticks is sampled a chunk at a time (the check's memory bounded): the same problems,
    notes and summary as one chunk, the chunk boundaries falling between trims and within the reference's moves."""
    from tiltload.master.app.feasibility import trajectory_check
    from tiltload.master.app.feasibility.trajectory_check import Limits, check_reference

    cases = [({"trajectory": 2}, {}, Limits()), ({"trajectory": 3}, {"m_L": 2.0}, Limits(f_max=12.0, max_tilt=5.0)),
             ({"trajectory": 1}, {"l": 1.2}, Limits(tau_max=0.01))]
    whole = [vars(check_reference(s, 20.0, "load", plant, limits)) for s, plant, limits in cases]
    monkeypatch.setattr(trajectory_check, "CHUNK", 237)  # 1667 ticks: 8 chunks, none a multiple of the trims' 10
    trajectory_check._REFERENCES.clear()
    chunked = [vars(check_reference(s, 20.0, "load", plant, limits)) for s, plant, limits in cases]
    trajectory_check._REFERENCES.clear()
    assert chunked == whole
    assert any(r["problems"] for r in whole) and any(not r["problems"] for r in whole)


def test_a_case_that_moves_only_the_start_shares_the_check_s_verdict(fmus):
    from tiltload.master.app.batch.worker import CaseWorker
    from tiltload.master.app.case.system import case_system
    from tiltload.master.app.falsify.spec import load
    from tiltload.master.app.feasibility.policy import check_system

    base = load(ROOT / "docs" / "falsification" / "tracking_wind_load.toml").base()
    systems = [case_system(fmus, base, "mixed", 1, {"plant.m_L": 3.0, "plant.x_0": x}) for x in (1.7, 1.9)]
    a, b = (vars(check_system(s, 8.1)) for s in systems)
    assert a == b  # the check reads no initial position: one verdict serves both
    worker = CaseWorker(keep=False)
    verdicts = [worker.infeasible(s, 8.1, base.trajectory) for s in systems]
    assert len(worker.verdicts) == 1 and verdicts[0] == verdicts[1]


def test_a_worker_keeps_a_bounded_number_of_verdicts_and_checks_again_what_it_let_go(fmus, monkeypatch):
    """A search that moves a mission makes a new verdict key at every point: the worker keeps the last MOST_VERDICTS,
    and a point whose verdict went is checked again (the same verdict), never answered from another's."""
    from tiltload.master.app.batch import worker as W
    from tiltload.master.app.case.system import case_system
    from tiltload.master.app.falsify.spec import load

    base = load(ROOT / "docs" / "falsification" / "tracking_wind_load.toml").base()
    systems = [case_system(fmus, base, "mixed", 1, {"plant.m_L": m}) for m in (0.05, 3.0, 7.5, 0.06)]
    checks = []
    real = W.check_system
    monkeypatch.setattr(W, "check_system", lambda *a, **k: checks.append(1) or real(*a, **k))
    monkeypatch.setattr(W, "MOST_VERDICTS", 3)
    worker = W.CaseWorker(keep=False)
    first = [worker.infeasible(s, 8.1, base.trajectory) for s in systems]  # the fourth pushes the first out
    assert len(worker.verdicts) == 3 and len(checks) == 4
    assert worker.infeasible(systems[0], 8.1, base.trajectory) == first[0] and len(checks) == 5  # checked again
    assert worker.infeasible(systems[3], 8.1, base.trajectory) == first[3] and len(checks) == 5  # still kept
    assert first[0] is None and first[2] is not None  # a feasible plant and an infeasible one


@pytest.mark.parametrize("spec", ["tracking_wind_load", "altitude_thrust_loss"])
def test_a_search_s_rows_on_a_warm_worker_are_each_point_s_run_alone_the_plain_way(fmus, spec, monkeypatch):
    from tiltload.master.app.batch.worker import CaseWorker
    from tiltload.master.app.falsify.evaluate import evaluate
    from tiltload.master.app.falsify.runner import make_case
    from tiltload.master.app.falsify.space import values_at
    from tiltload.master.app.falsify.spec import load

    spec = load(ROOT / "docs" / "falsification" / f"{spec}.toml")
    base = replace(spec.base(), early_stop=True)
    rng = np.random.default_rng(11)
    cases = [make_case(base)(f"r{i}", values_at(spec.dimensions, rng.random(len(spec.dimensions)))) for i in range(8)]
    warm = CaseWorker()
    try:
        ours = [evaluate(base, case, str(fmus), warm)["row"] for case in cases]
    finally:
        warm.close()
    assert warm.pool.instantiated == 1  # every later point restarted the pooled execution
    plain(monkeypatch)
    theirs = [evaluate(base, case, str(fmus), CaseWorker(keep=False))["row"] for case in cases]
    for a, b in zip(ours, theirs):
        assert a.keys() == b.keys()
        for key in a:
            if key not in TIMING:
                same = a[key] == b[key] or (isinstance(a[key], float) and math.isnan(a[key]) and math.isnan(b[key]))
                assert same, (key, a[key], b[key])


def test_a_batch_goes_as_tasks_of_equal_sizes_a_whole_number_a_worker():
    from tiltload.master.app.batch.dispatch import SHORTEST, even_chunks

    for runs in [*range(0, 300), *range(500, 1300, 37)]:
        for workers in range(1, 6):
            sizes = even_chunks(runs, workers)
            assert sum(sizes) == runs and all(s > 0 for s in sizes)
            if runs:
                assert max(sizes) - min(sizes) <= 1 and max(sizes) <= SHORTEST
                # as few tasks as SHORTEST allows, and a whole number of them a worker: none left alone with the last
                assert len(sizes) == min(runs, workers) if runs <= workers * SHORTEST else len(sizes) % workers == 0
                assert len(sizes) < workers * (math.ceil(runs / (workers * SHORTEST)) + 1)


def test_a_worker_keeps_the_memory_it_frees_where_dask_would_have_it_trimmed():
    """Dask starts its workers with MALLOC_TRIM_THRESHOLD_=65536: then every block past 128 KB is a mapping of its
    own, faulted in page by page at every allocation (2 MB blocks here: larger than any hole the heap may hold).
    keep_freed_memory undoes that (glibc only)."""
    import platform
    import subprocess
    import sys

    if platform.libc_ver()[0] != "glibc":
        pytest.skip("glibc's malloc only")
    probe = """
import ctypes, resource
from tiltload.master.app.batch.worker import keep_freed_memory
libc = ctypes.CDLL(None)
libc.malloc.restype, libc.malloc.argtypes, libc.free.argtypes = ctypes.c_void_p, [ctypes.c_size_t], [ctypes.c_void_p]
def faults():
    before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    for _ in range(50):
        block = libc.malloc(2_000_000)
        ctypes.memset(block, 1, 2_000_000)
        libc.free(block)
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before
faults()
print(faults(), keep_freed_memory(), (faults(), faults())[1])
"""
    done = subprocess.run([sys.executable, "-c", probe], env={**os.environ, "MALLOC_TRIM_THRESHOLD_": "65536"},
                          capture_output=True, text=True, check=True)
    before, kept, after = done.stdout.split()
    assert kept == "True"
    assert int(before) >= 50 * 400 and int(after) < 50  # 489 pages a block, then none but a handful

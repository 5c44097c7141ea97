"""tiltload falsify: the spec's checks, the optimizers on functions with known minima (no simulation), uniform random's
distribution, resume after a SIGKILL, and the counterexample's replay command bit for bit on a real short case."""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
import textwrap
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from tiltload.master.app.case.spec_file import SpecError
from tiltload.master.app.falsify import optimizers
from tiltload.master.app.falsify.search import read_parts, search
from tiltload.master.app.falsify.spec import Dimension, load

GOOD = """
name = "t"
optimizer = "uniform"
[base]
scenario = "fsi"
trajectory = 1
stop_time = 4.2
gusts = false
[[requirements]]
name = "swing"
formula = "always[1:4] (abs(plant.gamma_1) < 0.2)"
[[search]]
name = "amp"
target = "gust.amplitude"
range = [0.0, 20.0]
[[search]]
name = "heading"
target = "gust.direction"
range = [0.0, 360.0]
[gust]
start = 1.5
duration = 0.8
[budget]
simulations = 3
"""


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "f.toml"
    path.write_text(text)
    return path


def test_a_good_spec_loads(tmp_path):
    spec = load(write(tmp_path, GOOD))
    assert [d.target for d in spec.dimensions] == ["gust.amplitude", "gust.direction"]
    assert spec.signals == ("plant.gamma_1",) and spec.stop_time == 4.2 and spec.simulations == 3


def test_the_documented_spec_loads_as_written(tmp_path):
    """docs/falsification.md's annotated spec, placed as a spec in docs/falsification/ is (its requirement file is
    ../requirements/thesis.yaml), loads with both kinds of requirement."""
    docs = Path(__file__).resolve().parents[2] / "docs"
    text = (docs / "falsification.md").read_text(encoding="utf-8")
    block = text.split("```toml\n", 1)[1].split("```", 1)[0]
    (tmp_path / "requirements").mkdir()
    (tmp_path / "requirements" / "thesis.yaml").write_bytes((docs / "requirements" / "thesis.yaml").read_bytes())
    (tmp_path / "falsification").mkdir()
    spec = load(write(tmp_path / "falsification", block))
    assert [r.name for r in spec.requirements] == ["swing", "load_swing"]
    assert [d.target for d in spec.dimensions] == ["gust.amplitude"] and spec.simulations == 200


@pytest.mark.parametrize("change, says", [
    (("optimizer = \"uniform\"", "optimizer = \"annealing\""), "optimizer"),
    (("range = [0.0, 20.0]", "range = [20.0, 0.0]"), "search.0.range: low must be below high"),
    (("target = \"gust.amplitude\"", "target = \"gust.size\""), "search.0.target"),
    (("target = \"gust.amplitude\"", "target = \"faults.0.start\""), "names a fault base.faults does not have"),
    (("formula = \"always[1:4] (abs(plant.gamma_1) < 0.2)\"", "formula = \"always[1:4] (abs(plant.gamma_1) < \""),
     "requirements.0.formula"),
    (("formula = \"always[1:4] (abs(plant.gamma_1) < 0.2)\"", "formula = \"always[1:9] (abs(plant.gamma_1) < 0.2)\""),
     "horizon (9 s) is longer than the run"),
    (("formula = \"always[1:4] (abs(plant.gamma_1) < 0.2)\"", "formula = \"always[1:4] (abs(rotor.gamma_1) < 0.2)\""),
     "signal rotor.gamma_1 is not instance.variable"),
    (("[budget]\nsimulations = 3", "[budget]"), "budget"),
    (("name = \"heading\"", "name = \"amp\""), "search.1.name: amp is named twice"),
    (("scenario = \"fsi\"", "scenario = \"ekf\""), "base.scenario"),
])
def test_a_bad_spec_is_one_line_naming_the_field(tmp_path, change, says):
    old, new = change
    assert old in GOOD
    with pytest.raises(SpecError) as err:
        load(write(tmp_path, GOOD.replace(old, new, 1)))
    assert says in str(err.value) and "\n" not in str(err.value)


def test_the_command_refuses_a_bad_spec_with_exit_2(tmp_path):
    from tiltload.master.app.cli import main

    path = write(tmp_path, GOOD.replace("range = [0.0, 20.0]", "range = [1.0, 1.0]"))
    assert main(["falsify", str(path), "--out", str(tmp_path / "o")]) == 2
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("old, new, says", [
    ("formula = \"always[1:4] (abs(plant.gamma_1) < 0.2)\"", "formula = \"always[1:4] (abs(plant.gama_1) < 0.2)\"",
     "plant.gama_1 is not an output of plant (did you mean plant.gamma_1"),
    ("target = \"gust.direction\"", "target = \"plant.m_LL\"", "plant.m_LL is not a parameter of plant (did you mean plant.m_L"),
])
def test_names_are_checked_against_the_built_fmus_before_any_run(tmp_path, old, new, says):
    from tiltload.master.app.falsify.runner import check_names
    from tiltload.master.app.loop.fmus import build_all

    fmus = Path("fmus").resolve()
    build_all(fmus)
    with pytest.raises(SpecError, match=says.replace("(", r"\(").replace(".", r"\.")):
        check_names(load(write(tmp_path, GOOD.replace(old, new))), fmus)


def sphere(centre):
    return lambda x: float(np.sum((np.asarray(x) - centre) ** 2))


@pytest.mark.parametrize("name, budget, tolerance", [("cmaes", 600, 1e-8), ("tpe", 150, 2e-2), ("neldermead", 300, 1e-6)])
def test_optimizers_find_a_known_minimum(name, budget, tolerance):
    centre = np.array([0.3, 0.7, 0.55])
    points, values = optimizers.minimize(name, sphere(centre), 3, budget, seed=4)
    best = int(np.argmin(values))
    assert values[best] < tolerance
    assert np.all(np.abs(points[best] - centre) < math.sqrt(tolerance) + 1e-12)
    assert np.all((points >= 0) & (points <= 1))
    # far better than uniform random with the same budget on the same function
    _, uniform = optimizers.minimize("uniform", sphere(centre), 3, budget, seed=4)
    assert values[best] < min(uniform) / 5


@pytest.mark.parametrize("name", ["cmaes", "neldermead"])
def test_a_minimum_in_a_corner_is_reached_inside_the_bounds(name):
    points, values = optimizers.minimize(name, sphere(np.array([1.0, 0.0])), 2, 400, seed=1)
    assert min(values) < 1e-6 and np.all((points >= 0) & (points <= 1))


def test_nelder_mead_restarts_when_its_simplex_collapses():
    """A function with two basins: a simplex that collapsed into the shallow one starts again elsewhere (a restart
    asks a new simplex of d + 1 points), so the deep one is found within the budget."""
    deep, shallow = np.array([0.9, 0.9]), np.array([0.2, 0.2])

    def two_basins(x):
        x = np.asarray(x)
        return float(min(np.sum((x - shallow) ** 2), np.sum((x - deep) ** 2) - 0.5))

    opt = optimizers.make("neldermead", 2, 0)
    starts, values = 0, []
    while len(values) < 2000:
        if opt.phase == "start":
            starts += 1
        asked = opt.ask()
        got = [two_basins(x) for x in asked]
        opt.tell(asked, got)
        values.extend(got)
    assert starts > 1 and min(values) < -0.5 + 1e-6


def test_uniform_random_is_uniform_and_independent_and_seeded():
    from scipy import stats

    opt = optimizers.make("uniform", 3, seed=11, batch=500)
    x = np.vstack([opt.ask() for _ in range(8)])  # 4000 points
    for k in range(3):
        assert stats.kstest(x[:, k], "uniform").pvalue > 1e-3
    corr = np.corrcoef(x.T)
    assert np.all(np.abs(corr[np.triu_indices(3, 1)]) < 4 / math.sqrt(len(x)))  # ~4 sigma for independent coordinates
    again = optimizers.make("uniform", 3, seed=11, batch=500).ask()
    assert np.array_equal(again, x[:500])
    assert not np.array_equal(optimizers.make("uniform", 3, seed=12, batch=500).ask(), x[:500])


def test_dimensions_map_the_cube_onto_their_ranges():
    d = Dimension("a", "plant.m_L", 0.02, 0.5)
    assert d.value(0.0) == 0.02 and d.value(1.0) == 0.5 and d.value(0.5) == pytest.approx(0.26)
    severity = Dimension("s", "scenario.dryden", 0, 3, integer=True)
    assert [severity.value(u) for u in (0.0, 0.2, 0.5, 0.9, 1.0)] == [0, 1, 2, 3, 3]


NEEDLE = np.array([0.8, 0.15])


def needle(unit) -> float:
    """Robustness of a synthetic requirement violated only within 0.05 of NEEDLE (a cone: minimum -0.05 there)."""
    return float(np.linalg.norm(np.asarray(unit) - NEEDLE) - 0.05)


def synthetic_batch(dims):
    def run(cases):
        return {c["run_id"]: {"run_id": c["run_id"], **c["values"], "robustness": needle(c["unit"]), "completed": True,
                              "error": ""} for c in cases}
    return run


DIMS = [Dimension("a", "plant.m_L", 0.0, 1.0), Dimension("b", "plant.l", 0.0, 1.0)]


def make_case(rid, values):
    return {"run_id": rid, "values": values, "parameters": {}}


@pytest.mark.parametrize("name", ["uniform", "cmaes", "tpe", "neldermead"])
def test_a_search_stops_at_its_first_falsification(name):
    out = search(DIMS, name, 3, synthetic_batch(DIMS), make_case, 3000, None, None, "needle")
    assert out.falsified_at is not None and out.simulations <= 3000
    first = out.rows[out.falsified_at]
    assert first["robustness"] < 0 and all(r["robustness"] >= 0 for r in out.rows[:out.falsified_at])
    assert np.linalg.norm(np.array([first["u_a"], first["u_b"]]) - NEEDLE) < 0.05
    assert out.simulations - out.falsified_at <= optimizers.make(name, 2, 3).batch  # at most the rest of its batch


@pytest.mark.parametrize("budget", [3000, 37])
def test_batches_asked_ahead_give_the_rows_of_a_batch_at_a_time(monkeypatch, budget):
    """uniform's batches go to the workers a group at a time: the same points, the same rows, the same stop at the
    first falsification (the group's later batches dropped) as when each batch is told before the next is asked."""
    calls = []

    def counted(cases):
        calls.append(len(cases))
        return {c["run_id"]: {**row, "wall_s": 0.01} for c, row in zip(cases, synthetic_batch(DIMS)(cases).values())}
    ahead = search(DIMS, "uniform", 3, counted, make_case, budget, None, None, "needle")
    grouped = list(calls)
    monkeypatch.setattr(optimizers.UniformRandom, "independent", False)
    calls.clear()
    one_by_one = search(DIMS, "uniform", 3, counted, make_case, budget, None, None, "needle")
    assert ahead.rows == one_by_one.rows and ahead.falsified_at == one_by_one.falsified_at
    assert set(calls) <= {4, 1} and max(grouped) > 4  # asked ahead: fewer, larger calls
    if budget == 37:
        assert ahead.falsified_at is None and ahead.simulations == 37


def test_not_falsified_within_the_budget_says_so(tmp_path):
    out = search(DIMS, "uniform", 0, lambda cases: {c["run_id"]: {**c["values"], "robustness": 1.0 + c["unit"][0],
                                                                   "run_id": c["run_id"]} for c in cases},
                 make_case, 10, None, tmp_path, "never")
    assert out.falsified_at is None and out.simulations == 10
    import pyarrow.parquet as pq

    rows = pq.read_table(tmp_path / "falsification.parquet").to_pylist()
    assert [r["index"] for r in rows] == list(range(10))


KILLER = """
import os, signal, sys
import numpy as np
from pathlib import Path
from tiltload.master.app.falsify.search import search
from tiltload.master.app.falsify.spec import Dimension

NEEDLE = np.array([0.8, 0.15])
kill_after = int(sys.argv[2])
dims = [Dimension("a", "plant.m_L", 0.0, 1.0), Dimension("b", "plant.l", 0.0, 1.0)]
done = [0]

def batch(cases):
    out = {}
    for c in cases:
        if kill_after and done[0] >= kill_after:
            os.kill(os.getpid(), signal.SIGKILL)
        out[c["run_id"]] = {"run_id": c["run_id"], **c["values"],
                            "robustness": float(np.linalg.norm(np.asarray(c["unit"]) - NEEDLE) - 0.01)}
        done[0] += 1
    return out

o = search(dims, sys.argv[3], 5, batch, lambda rid, v: {"run_id": rid, "values": v, "parameters": {}}, 60, None,
           Path(sys.argv[1]), "kill-test")
print(o.simulations, o.reused)
"""


@pytest.mark.slow
@pytest.mark.parametrize("name", ["cmaes", "tpe", "neldermead"])
def test_a_search_killed_half_way_resumes_as_if_uninterrupted(tmp_path, name):
    import pyarrow.parquet as pq

    script = tmp_path / "killer.py"
    script.write_text(textwrap.dedent(KILLER))
    env = {**os.environ, "PYTHONHASHSEED": "0"}
    killed = subprocess.run([sys.executable, str(script), str(tmp_path / "a"), "23", name], env=env, capture_output=True)
    assert killed.returncode == -signal.SIGKILL
    stored = read_parts(tmp_path / "a" / "parts")
    assert 0 < len(stored) <= 23
    resumed = subprocess.run([sys.executable, str(script), str(tmp_path / "a"), "0", name], env=env, capture_output=True,
                             text=True, check=True)
    whole = subprocess.run([sys.executable, str(script), str(tmp_path / "b"), "0", name], env=env, capture_output=True,
                           text=True, check=True)
    simulations, reused = map(int, resumed.stdout.split())
    assert reused == len(stored) and simulations == int(whole.stdout.split()[0]) > 23
    a = pq.read_table(tmp_path / "a" / "falsification.parquet").to_pylist()
    b = pq.read_table(tmp_path / "b" / "falsification.parquet").to_pylist()
    assert [(r["index"], r["u_a"], r["u_b"], r["robustness"]) for r in a] == \
           [(r["index"], r["u_a"], r["u_b"], r["robustness"]) for r in b]


SHORT = GOOD.replace("range = [0.0, 20.0]", "range = [14.0, 20.0]").replace("optimizer = \"uniform\"", "optimizer = \"cmaes\"")


@pytest.mark.slow
def test_the_counterexample_replays_bit_for_bit(tmp_path, monkeypatch):
    """A real 4 s case: the evaluation's robustness (an observer's trace) equals the one of the replay command's log."""
    from tiltload.master.app.cli import main
    from tiltload.master.app.falsify.evaluate import evaluate, robustness
    from tiltload.master.app.falsify.report import replay_command
    from tiltload.master.app.falsify.report import write as write_report
    from tiltload.master.app.falsify.runner import make_case as case_of
    from tiltload.master.app.falsify.signals import trace_from_log
    from tiltload.master.app.loop.fmus import build_all

    fmus = Path("fmus").resolve()
    build_all(fmus)
    spec = load(write(tmp_path, SHORT))
    base = spec.base()

    def batch(cases):
        return {c["run_id"]: evaluate(base, c, str(fmus))["row"] for c in cases}

    out = search(spec.dimensions, "cmaes", 2, batch, case_of(base), 3, None, tmp_path / "o", "replay")
    best = out.best
    assert best["completed"] or best["error"]
    write_report(spec, out, tmp_path / "o", fmus)
    args = replay_command(spec, best, tmp_path / "o", fmus)
    assert args[:2] == ["tiltload", "run"]
    code = main(args[1:] + ["--quiet", "--no-plots"])
    assert code in (0, 1)  # 1: the loop diverged, as it did in the search (the log holds what it got)
    trace = trace_from_log(tmp_path / "o" / "counterexample" / "counterexample.mcap", list(spec.signals), 0.012)
    rho, _ = robustness([r.formula for r in spec.requirements], trace, best["error"] == "")
    assert rho[0] == best["rho_swing"]  # bit for bit
    assert min(rho) == best["robustness"]
    summary = (tmp_path / "o" / "summary.txt").read_text()
    assert ("FALSIFIED after" in summary) == (best["robustness"] < 0)
    assert "tiltload run" in summary


@pytest.mark.slow
def test_the_command_on_a_local_cluster_says_not_falsified_and_a_rerun_takes_the_stored_evaluations(tmp_path, capsys):
    from tiltload.master.app.cli import main

    easy = GOOD.replace("< 0.2)", "< 10.0)").replace("range = [0.0, 20.0]", "range = [0.0, 1.0]")
    path = write(tmp_path, easy)
    args = ["falsify", str(path), "--out", str(tmp_path / "o"), "--workers", "1", "--simulations", "2"]
    assert main(args) == 0
    said = capsys.readouterr().out
    assert "NOT FALSIFIED in 2 simulations (a search is no proof)" in said and "tiltload run" in said
    import pyarrow.parquet as pq

    rows = pq.read_table(tmp_path / "o" / "falsification.parquet").to_pylist()
    assert len(rows) == 2 and all(r["robustness"] > 0 and r["worker"] for r in rows)
    assert main(args) == 0
    assert "2 simulations in" in (said := capsys.readouterr().out) and "(2 from the previous run)" in said


THRUST = """
name = "thrust"
optimizer = "uniform"
[base]
scenario = "fsi"
trajectory = 1
controller = "mixed"
stop_time = 8.1
gusts = false
faults = [{name = "right rotor thrust loss", action = "scale", target = "plant.f_R", value = 0.7, start = 3.0, end = 3.5}]
[[requirements]]
name = "altitude"
formula = "always[2:8] (abs(plant.z - scenario.z_ref) < 0.15)"
[[search]]
name = "thrust_left"
target = "faults.0.value"
range = [0.6, 1.0]
[[search]]
name = "loss_start"
target = "faults.0.start"
range = [2.0, 5.0]
[[search]]
name = "loss_length"
target = "faults.0.duration"
range = [0.1, 1.0]
[budget]
simulations = 4
"""


def _thrust_case(tmp_path, unit):
    from tiltload.master.app.falsify.space import case_parameters, values_at

    spec = load(write(tmp_path, THRUST))
    base = spec.base()
    values = values_at(spec.dimensions, np.asarray(unit, dtype=float))
    return spec, base, {"run_id": "t", "values": values, "parameters": case_parameters(base, values)}


def test_the_recorders_common_length_is_its_common_traces_length():
    """The early-stop check's length of the trace so far (from each signal's first and last record: it skips making
    the trace while every formula reads later) is the length of the trace it would make, for signals at other rates
    and starts (a slower instance's last record behind, a record at the start only)."""
    from tiltload.master.app.falsify.signals import SignalRecorder

    rng = np.random.default_rng(3)
    tick = 0.012
    for _ in range(200):
        recorder = SignalRecorder(["a.x", "b.y", "c.z"])
        recorder.tick = tick
        for name in recorder.names:
            every, first = int(rng.integers(1, 9)), int(rng.integers(0, 4))
            last = first + int(rng.integers(0, 300))
            times = np.arange(first, last + 1, every) * tick
            parts = [times[:1]] + ([times[1:]] if times.size > 1 else [])  # as start and on_batch append them
            recorder._times[name] = parts
            recorder._values[name] = [rng.normal(size=part.size) for part in parts]
        assert recorder.common_length() == len(recorder.trace(common=True))


@pytest.mark.slow
def test_an_early_stopped_run_reports_the_bound_of_its_prefix_against_brute_force_on_the_whole_trace(tmp_path):
    """Stopped at a decided violation: its robustness is the lowest margin of the always's predicate over the window so
    far (brute force on the whole run's trace, cut at the stop), below 0 and at least the whole run's robustness; a run
    that passes is not stopped and has the whole run's robustness, bit for bit."""
    from tiltload.master.app.falsify.evaluate import evaluate, run_loop
    from tiltload.master.app.falsify.signals import SignalRecorder
    from tiltload.master.app.loop.fmus import build_all

    fmus = Path("fmus").resolve()
    build_all(fmus)
    stopped = 0
    for unit in ([0.0, 0.1, 1.0], [0.0, 0.9, 1.0], [0.5, 0.5, 0.5], [1.0, 0.5, 0.5]):
        spec, base, case = _thrust_case(tmp_path, unit)
        recorder = SignalRecorder(list(spec.signals))
        run_loop(base, case["parameters"], fmus, [recorder])
        trace = recorder.trace()
        z, ref = trace.signals["plant.z"], trace.signals["scenario.z_ref"]
        window = (trace.times >= 2.0 - 1e-9) & (trace.times <= 8.0 + 1e-9)
        whole = float(np.min(0.15 - np.abs(z - ref)[window]))
        early = evaluate(replace(base, early_stop=True), case, str(fmus))["row"]
        assert evaluate(base, case, str(fmus))["row"]["robustness"] == pytest.approx(whole, abs=1e-12)
        if math.isnan(early["stopped_at"]):
            assert whole >= 0 and early["robustness"] == evaluate(base, case, str(fmus))["row"]["robustness"]
            continue
        stopped += 1
        assert early["stopped_at"] < 8.0 and early["verdict_altitude"] == "FAIL"
        cut = window & (trace.times <= early["stopped_at"] + 1e-9)
        assert early["robustness"] == pytest.approx(float(np.min(0.15 - np.abs(z - ref)[cut])), abs=1e-12)
        assert whole <= early["robustness"] < 0
    assert stopped >= 2


@pytest.mark.slow
def test_a_branch_from_a_snapshot_is_the_whole_run_bit_for_bit(tmp_path):
    from tiltload.master.app.falsify.branching import branch_tick, choose, with_branch
    from tiltload.master.app.falsify.evaluate import run_loop
    from tiltload.master.app.falsify.signals import SignalRecorder
    from tiltload.master.app.loop.fmus import build_all
    from tiltload.master.app.loop.thesis import TICK

    fmus = Path("fmus").resolve()
    build_all(fmus)
    spec, base, _ = _thrust_case(tmp_path, [0.5, 0.5, 0.5])
    ticks = branch_tick(spec.dimensions, base.faults, TICK)
    assert ticks == 165  # the last tick before 2 s (the earliest start), one tick earlier
    branched = with_branch(base, ticks)
    for unit in ([0.0, 0.0, 1.0], [0.3, 0.7, 0.2], [0.0, 0.1, 1.0]):
        _, _, case = _thrust_case(tmp_path, unit)
        traces = []
        for b, branch in ((base, False), (branched, True)):
            recorder = SignalRecorder(list(spec.signals))
            run_loop(b, case["parameters"], fmus, [recorder], branch=branch)
            traces.append(recorder.trace())
        assert np.array_equal(traces[0].times, traces[1].times)
        for name in spec.signals:
            assert np.array_equal(traces[0].signals[name], traces[1].signals[name])  # bit for bit
    use, line = choose(base, spec.dimensions, fmus, ticks, repeat=1)
    assert "branching from a snapshot at t = 1.980 s" in line and ("not used" in line) != use


def test_only_faults_that_start_late_are_branched():
    from tiltload.master.app.falsify.branching import branch_tick

    faults = [{"name": "f", "action": "scale", "target": "plant.f_R", "value": 0.7, "start": 3.0, "end": 3.5}]
    start = Dimension("s", "faults.0.start", 2.0, 5.0)
    value = Dimension("v", "faults.0.value", 0.5, 1.0)
    assert branch_tick([value], faults, 0.012) == 249  # 3.0 s is tick 250: the one before, less one
    assert branch_tick([start, value], faults, 0.012) == 165
    assert branch_tick([value, Dimension("g", "gust.amplitude", 0.0, 5.0)], faults, 0.012) is None  # a gust: from t = 0
    assert branch_tick([value, Dimension("m", "plant.m_L", 0.04, 0.08)], faults, 0.012) is None
    assert branch_tick([value], [{**faults[0], "action": "delay", "value": 3}], 0.012) is None  # looks back before start
    assert branch_tick([Dimension("s", "faults.0.start", 0.0, 5.0)], faults, 0.012) is None  # no prefix worth it


@pytest.mark.slow
def test_an_early_stopped_counterexample_replays_the_whole_run_the_summary_states(tmp_path):
    from tiltload.master.app.cli import main
    from tiltload.master.app.falsify.evaluate import evaluate, robustness
    from tiltload.master.app.falsify.report import replay_command
    from tiltload.master.app.falsify.report import write as write_report
    from tiltload.master.app.falsify.signals import trace_from_log
    from tiltload.master.app.loop.fmus import build_all

    fmus = Path("fmus").resolve()
    build_all(fmus)
    spec, base, case = _thrust_case(tmp_path, [0.0, 0.1, 1.0])
    row = evaluate(replace(base, early_stop=True), case, str(fmus))["row"]
    assert row["stopped_at"] < 8.0
    out = search(spec.dimensions, "uniform", 0, lambda cases: {c["run_id"]: {**row, "run_id": c["run_id"]} for c in cases},
                 lambda rid, v: {"run_id": rid, "values": v, "parameters": {}}, 1, None, tmp_path / "o", "early")
    write_report(spec, out, tmp_path / "o", fmus)
    summary = (tmp_path / "o" / "summary.txt").read_text()
    assert "upper bound over every continuation" in summary
    stated = float(summary.split("the whole run (what replay.sh runs): robustness ")[1].split()[0])
    assert main(replay_command(spec, out.best, tmp_path / "o", fmus)[1:] + ["--quiet", "--no-plots"]) in (0, 1)
    trace = trace_from_log(tmp_path / "o" / "counterexample" / "counterexample.mcap", list(spec.signals), 0.012)
    rho, _ = robustness([r.formula for r in spec.requirements], trace, True)
    assert rho[0] == stated <= row["robustness"] < 0  # the replay is the whole run, bit for bit


REQS = """requirements:
  - name: low_swing
    description: the rod stays near the vertical
    formula: always[1:4] (abs(plant.gamma_1) < 0.3)
  - name: cap_f_R
    bounds: {signal: controller.f_R, min: 0, max: 30}
"""


def test_requirements_are_named_from_a_requirement_file_beside_formulas(tmp_path):
    (tmp_path / "reqs.yaml").write_text(REQS)
    named = GOOD.replace("[[search]]", '[[requirements]]\nfile = "reqs.yaml"\nname = "cap_f_R"\n[[search]]', 1)
    spec = load(write(tmp_path, named))
    assert [r.name for r in spec.requirements] == ["swing", "cap_f_R"]
    # the bounds sugar, expanded by the requirements' loader (docs/requirements.md): within [0, 30] the whole run
    assert spec.requirements[1].formula.replace(" ", "") == "always(controller.f_R>=0.0andcontroller.f_R<=30.0)"
    assert set(spec.signals) == {"plant.gamma_1", "controller.f_R"}
    every = GOOD.replace("[[search]]", '[[requirements]]\nfile = "reqs.yaml"\n[[search]]', 1)
    spec = load(write(tmp_path, every))
    assert [r.name for r in spec.requirements] == ["swing", "low_swing", "cap_f_R"]
    assert spec.requirements[1].formula == "always[1:4] (abs(plant.gamma_1) < 0.3)"
    assert spec.requirements[1].description == "the rod stays near the vertical"


@pytest.mark.parametrize("file_text, entry, says", [
    (REQS, 'file = "reqs.yaml"\nname = "low_swig"', "has no requirement low_swig (did you mean low_swing?)"),
    (REQS, 'file = "nothere.yaml"', "requirements.1.file: no requirement file"),
    ("requirements:\n  - &a {name: x, formula: always plant.z > 0}\n  - *a\n", 'file = "reqs.yaml"', "alias"),
    ("requirements:\n  - {name: x, formula: always plant.z >}\n", 'file = "reqs.yaml"', "requirement 'x'"),
    (REQS.replace("< 0.3)", "< 0.3)\n  - name: low_swing\n    formula: always plant.z > 0"), 'file = "reqs.yaml"',
     "named twice"),
    (REQS.replace("low_swing", "swing"), 'file = "reqs.yaml"', "swing is named twice"),
])
def test_a_bad_requirement_file_is_one_line(tmp_path, file_text, entry, says):
    (tmp_path / "reqs.yaml").write_text(file_text)
    with pytest.raises(SpecError) as err:
        load(write(tmp_path, GOOD.replace("[[search]]", f"[[requirements]]\n{entry}\n[[search]]", 1)))
    assert says in str(err.value) and "\n" not in str(err.value)


def test_a_neighbourhood_axis_is_centred_clipped_and_rounded():
    from tiltload.master.app.falsify.neighbourhood import axis

    d = Dimension("v", "faults.0.value", 0.6, 1.0)
    assert axis(d, 0.8, 0.1, 5) == pytest.approx([0.76, 0.78, 0.8, 0.82, 0.84])
    assert axis(d, 0.61, 0.1, 5) == pytest.approx([0.6, 0.61, 0.6125, 0.625, 0.6375, 0.65])  # clipped; the centre kept
    assert axis(Dimension("s", "sensors.seed", 0, 100, True), 50.4, 0.1, 5) == [40, 45, 50, 55, 60]


def test_the_failure_region_s_width_is_measured_along_the_line_through_the_counterexample():
    from tiltload.master.app.falsify.neighbourhood import grid, widths
    from tiltload.master.app.falsify.spec import Falsification

    dims = [Dimension("a", "plant.m_L", 0.0, 1.0), Dimension("b", "plant.l", 0.0, 1.0)]
    spec = Falsification.__new__(Falsification)
    spec.dimensions = dims
    best = {"a": 0.5, "b": 0.5}
    axes, points = grid(spec, best, 0.1, 5)  # a and b in 0.4, 0.45, ..., 0.6
    rows = [{**p, "robustness": abs(p["a"] - 0.5) - 0.06} for p in points]  # fails where |a - 0.5| < 0.06, any b
    w = widths(spec, best, axes, rows)
    assert w["a"]["line_fails"] == "3/5" and w["a"]["line_width"] == pytest.approx(0.1)
    assert w["b"]["line_fails"] == "5/5" and w["b"]["line_width"] == pytest.approx(0.2) == w["b"]["line_span"]


@pytest.mark.slow
def test_the_neighbourhood_of_a_counterexample_runs_and_its_campaign_spec_is_the_same_grid(tmp_path):
    import pyarrow.parquet as pq
    from tiltload.master.app.campaign.spec import load as load_campaign
    from tiltload.master.app.falsify import neighbourhood
    from tiltload.master.app.falsify.evaluate import evaluate
    from tiltload.master.app.falsify.runner import make_case as case_of
    from tiltload.master.app.loop.fmus import build_all

    fmus = Path("fmus").resolve()
    build_all(fmus)
    text = THRUST.replace("[[search]]\nname = \"loss_length\"\ntarget = \"faults.0.duration\"\nrange = [0.1, 1.0]\n", "")
    spec = load(write(tmp_path, text.replace("end = 3.5", "end = 4.5")))
    base = spec.base()
    best = {"thrust_left": 0.62, "loss_start": 2.3}
    said = neighbourhood.run(spec, best, lambda cases: {c["run_id"]: evaluate(base, c, str(fmus))["row"] for c in cases},
                             case_of(base), tmp_path, 0.1, 3)
    rows = pq.read_table(tmp_path / "neighbourhood" / neighbourhood.RESULTS).to_pylist()
    assert len(rows) == 4 * 3  # thrust 0.6 (clipped), 0.63, 0.66 and the centre 0.62; start 2.0, 2.3 (the centre), 2.6
    failing = sum(r["robustness"] < 0 for r in rows)
    assert f"{failing} fail: {failing / len(rows):.1%} of the grid" in said
    assert (tmp_path / "neighbourhood" / neighbourhood.FIGURE).is_file()
    campaign = load_campaign(tmp_path / "neighbourhood" / neighbourhood.CAMPAIGN)
    assert sorted((c.values["thrust_left"], c.values["loss_start"]) for c in campaign.cases) == \
           sorted((r["thrust_left"], r["loss_start"]) for r in rows)


MISSION = "t,x,y,z\n0,0,0,1\n2,0.5,0,1.2\n4,0.5,0.5,1.2\n"
MOVED = GOOD.replace('trajectory = 1', 'trajectory = "m.csv"').replace(
    "always[1:4] (abs(plant.gamma_1) < 0.2)", "always[1:4] (abs(plant.y - scenario.y_ref) < 0.05)").replace(
    'target = "gust.amplitude"\nrange = [0.0, 20.0]', 'target = "waypoints.1.y"\nrange = [-0.4, 0.4]').replace(
    'target = "gust.direction"\nrange = [0.0, 360.0]', 'target = "waypoints.2.t"\nrange = [-1.5, 1.0]')


@pytest.mark.parametrize("old, new, says", [
    ("waypoints.1.y", "waypoints.3.y", "names a waypoint the mission does not have (it has 3: 0 to 2)"),
    ('trajectory = "m.csv"', "trajectory = 1", "base.trajectory must be a waypoint file"),
    ("waypoints.1.y", "waypoints.1.vx", "search.0.target"),
])
def test_a_bad_waypoint_dimension_is_one_line(tmp_path, old, new, says):
    (tmp_path / "m.csv").write_text(MISSION)
    with pytest.raises(SpecError) as err:
        load(write(tmp_path, MOVED.replace(old, new, 1)))
    assert says in str(err.value) and "\n" not in str(err.value)


@pytest.mark.slow
def test_a_moved_waypoint_is_searched_and_its_counterexample_replays_bit_for_bit(tmp_path):
    from tiltload.master.app.cli import main
    from tiltload.master.app.falsify.evaluate import evaluate, robustness
    from tiltload.master.app.falsify.report import MISSION as MOVED_FILE
    from tiltload.master.app.falsify.report import replay_command
    from tiltload.master.app.falsify.report import write as write_report
    from tiltload.master.app.falsify.runner import make_case as case_of
    from tiltload.master.app.falsify.signals import trace_from_log
    from tiltload.master.app.loop.fmus import build_all

    fmus = Path("fmus").resolve()
    build_all(fmus)
    (tmp_path / "m.csv").write_text(MISSION)
    spec = load(write(tmp_path, MOVED))
    base = spec.base()
    make = case_of(base)
    rows = {}
    for name, values in (("still", {"amp": 0.0, "heading": 0.0}), ("moved", {"amp": 0.4, "heading": 0.0}),
                         ("steep", {"amp": 0.0, "heading": -1.5}), ("disorder", {"amp": 0.0, "heading": -2.5})):
        rows[name] = evaluate(base, make(name, values), str(fmus))["row"]
    # moving waypoint 1 by 0.4 m in y changes the run; waypoint 2 half a second after waypoint 1 asks for more tilt than
    # the feasibility check allows (it judges the moved mission); moved before waypoint 1 it is no mission: refused
    assert rows["still"]["robustness"] != rows["moved"]["robustness"]
    assert "the reference is infeasible" in rows["steep"]["error"] and math.isnan(rows["steep"]["robustness"])
    assert "moved mission" in rows["disorder"]["error"] and math.isnan(rows["disorder"]["robustness"])
    out = search(spec.dimensions, "uniform", 0, lambda cases: {c["run_id"]: {**rows["moved"], "run_id": c["run_id"]}
                                                                for c in cases},
                 make, 1, None, tmp_path / "o", "moved")
    write_report(spec, out, tmp_path / "o", fmus)
    args = replay_command(spec, out.best, tmp_path / "o", fmus)
    assert args[args.index("--trajectory") + 1] == str((tmp_path / "o" / MOVED_FILE).resolve())
    assert main(args[1:] + ["--quiet", "--no-plots"]) in (0, 1)
    trace = trace_from_log(tmp_path / "o" / "counterexample" / "counterexample.mcap", list(spec.signals), 0.012)
    rho, _ = robustness([r.formula for r in spec.requirements], trace, rows["moved"]["error"] == "")
    assert rho[0] == rows["moved"]["robustness"]  # bit for bit: the moved mission's file gives the same reference


@pytest.mark.slow
def test_the_command_runs_the_neighbourhood_and_says_what_it_found(tmp_path, capsys):
    from tiltload.master.app.cli import main

    easy = GOOD.replace("< 0.2)", "< 10.0)").replace("range = [0.0, 20.0]", "range = [0.0, 1.0]")
    args = ["falsify", str(write(tmp_path, easy)), "--out", str(tmp_path / "o"), "--workers", "1", "--simulations", "2",
            "--neighbourhood", "--neighbourhood-points", "2", "--branch", "off"]
    assert main(args) == 0
    said = capsys.readouterr().out
    assert "neighbourhood of the counterexample:" in said and "0 fail: 0.0% of the grid" in said
    assert (tmp_path / "o" / "neighbourhood" / "neighbourhood.png").is_file()
    # gust dimensions: no campaign spec (a campaign cannot set a gust from one value), said so
    assert "no campaign spec" in said and not (tmp_path / "o" / "neighbourhood" / "neighbourhood_campaign.toml").exists()


@pytest.mark.slow
def test_a_search_on_the_cluster_branched_from_snapshots_stores_what_whole_runs_give(tmp_path):
    import pyarrow.parquet as pq
    from tiltload.master.app.falsify.runner import falsify

    path = write(tmp_path, THRUST)
    said = []
    runs = {}
    for branch in ("off", "on"):
        falsify(path, tmp_path / branch, simulations=4, workers=1, branch=branch, progress=said.append)
        runs[branch] = pq.read_table(tmp_path / branch / "falsification.parquet").to_pylist()
    summaries = [(tmp_path / b / "summary.txt").read_text() for b in ("off", "on")]  # said once: in the summary
    assert "branching from a snapshot: off" in summaries[0] and "branching from a snapshot at t = 1.980 s: on" in summaries[1]
    assert [r["robustness"] for r in runs["off"]] == [r["robustness"] for r in runs["on"]]  # bit for bit
    assert [r["stopped_at"] for r in runs["off"]] == pytest.approx([r["stopped_at"] for r in runs["on"]], nan_ok=True)

"""docs/exit_codes.md, command by command on cheap cases (runs of 1-2 s, budgets of 1 simulation): 0 only when what
was asked holds, 1 a test failed (a FAIL, a difference, a counterexample, a campaign with a failed run or requirement),
2 what the user can fix, 3 inconclusive."""

from __future__ import annotations

import pytest
from tiltload.master.app.cli import main


def _code(argv) -> int:
    try:
        return main(argv)
    except SystemExit as exit_:  # argparse
        return exit_.code


@pytest.fixture(scope="module")
def runs(fmus, tmp_path_factory):
    """Two 1 s runs' logs (trajectories 1 and 2), and requirement files that pass, fail and cannot be decided on them."""
    folder = tmp_path_factory.mktemp("exit_codes")
    for name, trajectory in (("a", "1"), ("b", "2")):
        assert _code(["run", "--scenario", "fsi", "--stop-time", "1", "--trajectory", trajectory, "--fmus", str(fmus),
                      "--out", str(folder), "--name", name, "--quiet", "--no-plots"]) == 0
    reqs = {"pass": "always plant.z < 100", "fail": "always plant.z > 100", "open": "always[0:0.5] 0 / 0 < plant.z",
            "vacuous": "always (plant.z > 100 implies plant.z < -100)"}
    for name, formula in reqs.items():
        (folder / f"{name}.yaml").write_text(f'requirements:\n  - {{name: r, formula: "{formula}"}}\n')
    return folder


def test_check(runs, capsys):
    log = str(runs / "a.mcap")
    assert [_code(["check", str(runs / f"{r}.yaml"), log]) for r in ("pass", "vacuous", "fail", "open")] == [0, 0, 1, 3]
    assert _code(["check", str(runs / "none.yaml"), log]) == 2
    assert _code(["check", log, "--formula", "r: always[0:9] plant.z < 100"]) == 2  # looks past the run


def test_run(fmus, runs, tmp_path, capsys):
    base = ["run", "--scenario", "fsi", "--stop-time", "1", "--fmus", str(fmus), "--out", str(tmp_path), "--quiet",
            "--no-plots", "--no-log"]
    got = [_code([*base, "--requirements", str(runs / f"{r}.yaml")]) for r in ("pass", "vacuous", "fail", "open")]
    assert got == [0, 0, 1, 3]
    assert "PASS (vacuous)" in capsys.readouterr().out  # run's table says so
    assert _code([*base, "--stop-time", "x"]) == 2
    (tmp_path / "far.yaml").write_text('requirements:\n  - {name: r, formula: "always[0:1e308] plant.z < 100"}\n')
    assert _code([*base, "--requirements", str(tmp_path / "far.yaml")]) == 2  # refused before it runs, as check does
    assert "looks 1e+308 s ahead" in capsys.readouterr().err


def test_compare_and_plot(runs, tmp_path):
    a, b = str(runs / "a.mcap"), str(runs / "b.mcap")
    assert _code(["compare", a, a]) == 0
    assert _code(["compare", a, b]) == 2  # different cases: the user asked for what is not comparable
    assert _code(["compare", a, b, "--any-case"]) == 1  # another trajectory: the metrics differ
    assert _code(["compare", a, str(tmp_path / "none.json")]) == 2
    assert _code(["plot", a, "--out", str(tmp_path / "plots")]) == 0
    assert _code(["plot", str(tmp_path / "none.mcap"), "--out", str(tmp_path / "plots")]) == 2


FALSIFY = """
name = "t"
optimizer = "uniform"
[base]
scenario = "fsi"
trajectory = 1
stop_time = 1.0
gusts = false
[[requirements]]
name = "r"
formula = "always[0:0.9] {body}"
[[search]]
name = "amp"
target = "gust.amplitude"
range = [0.0, 1.0]
[gust]
start = 0.2
duration = 0.3
[budget]
simulations = 1
"""


@pytest.mark.slow
def test_falsify_a_counterexample_is_a_failing_test(fmus, tmp_path, capsys):
    codes = {}
    for label, body in (("holds", "(plant.z > 100 implies plant.z < -100)"), ("falsified", "plant.z > 100")):
        spec = tmp_path / f"{label}.toml"
        spec.write_text(FALSIFY.replace("{body}", body))
        codes[label] = _code(["falsify", str(spec), "--out", str(tmp_path / label), "--fmus", str(fmus), "--workers", "1"])
    import pyarrow.parquet as pq

    (row,) = pq.read_table(tmp_path / "holds" / "falsification.parquet").to_pylist()
    assert row["verdict_r"] == "PASS (vacuous)"  # its trigger never held: stored as such
    (tmp_path / "bad.toml").write_text(FALSIFY.replace("{body}", "plant.z > 1e999"))
    codes["bad spec"] = _code(["falsify", str(tmp_path / "bad.toml"), "--out", str(tmp_path / "bad"), "--fmus", str(fmus)])
    assert codes == {"holds": 0, "falsified": 1, "bad spec": 2}


CAMPAIGN = """
name = "c"
[base]
scenario = "fsi"
trajectory = 1
controllers = ["mixed"]
stop_time = 1.0
[vary]
seeds = [1]
[keep]
requirements = "reqs.yaml"
"""


@pytest.mark.slow
def test_campaign_a_failed_requirement_fails_it_unless_allowed(fmus, runs, tmp_path, capsys):
    codes = {}
    for label in ("pass", "fail"):
        folder = tmp_path / label
        folder.mkdir()
        (folder / "reqs.yaml").write_text((runs / f"{'vacuous' if label == 'pass' else label}.yaml").read_text())
        (folder / "c.toml").write_text(CAMPAIGN)
        argv = ["campaign", str(folder / "c.toml"), "--fmus", str(fmus), "--out", str(folder / "out"), "--workers", "1"]
        codes[label] = _code(argv)
        if label == "fail":
            assert "requirement r FAILed in 1 run(s)" in capsys.readouterr().err
            codes["fail, allowed"] = _code([*argv, "--allow-failures"])  # the stored run, judged again: no new run
    (tmp_path / "bad.toml").write_text(CAMPAIGN + "bogus = 1\n")
    codes["bad spec"] = _code(["campaign", str(tmp_path / "bad.toml"), "--fmus", str(fmus), "--out", str(tmp_path / "o")])
    assert codes == {"pass": 0, "fail": 1, "fail, allowed": 0, "bad spec": 2}
    import pyarrow.parquet as pq

    (row,) = pq.read_table(tmp_path / "pass" / "out" / "results.parquet").to_pylist()
    assert row["r_verdict"] == "PASS (vacuous)"  # a vacuous pass passes the campaign, and its column says so
    assert _code(["campaign-report", str(tmp_path / "pass" / "out" / "results.parquet")]) == 0
    report = next((tmp_path / "pass" / "out").rglob("*.md")).read_text()
    assert "| r | 1 (1 vacuous) | 0 | 0 | 0 | 0 | 100 % |" in report  # PASS, FAIL, INCONCLUSIVE, ZERO, ERROR


def test_the_builders_exit_0_when_done_and_2_on_bad_input(fmus, tmp_path):
    """layout, wrap: 0 once done; wrap and build: 2 for what the user can fix (a missing file, an untraceable class, an
    output folder under a file). A build that runs is tested where the FMUs are (tests/fmus)."""
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    assert _code(["layout", str(tmp_path / "layout.json")]) == 0 and (tmp_path / "layout.json").is_file()
    assert _code(["wrap", str(root / "docs" / "examples" / "hover_lqr.py"), "--out", str(tmp_path / "c.fmu")]) == 0
    assert _code(["wrap", str(tmp_path / "missing.py")]) == 2
    bang = tmp_path / "bang.py"  # a Python decision on a signal: no native FMU
    bang.write_text("class Bang:\n    inputs = ['exact_z', 'z_ref']\n\n    def step(self, t, inputs):\n"
                    "        if inputs['z_ref'] > inputs['exact_z']:\n            return 10.0, 10.0, 0.0, 0.0\n"
                    "        return 9.0, 9.0, 0.0, 0.0\n")
    assert _code(["wrap", "--native", str(bang), "--out", str(tmp_path / "n.fmu")]) == 2
    (tmp_path / "a_file").write_text("")
    assert _code(["build", "--out", str(tmp_path / "a_file" / "fmus")]) == 2


@pytest.mark.slow
def test_reproduce_fails_when_a_case_differs_from_its_baseline(fmus, tmp_path):
    """reproduce --check: 0 with the committed baselines; 1 once one baseline's metric is moved out of its tolerance."""
    import json
    import shutil
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    baselines = shutil.copytree(root / "baselines", tmp_path / "baselines")
    common = ["reproduce", "--fmus", str(fmus), "--out", str(tmp_path / "out"), "--baselines", str(baselines), "--check"]
    assert _code(common) == 0
    moved = baselines / "fsi_traj1_dlqr.json"
    data = json.loads(moved.read_text())
    data["metrics"]["ISE(x)"] = float(data["metrics"]["ISE(x)"]) * 1.5
    moved.write_text(json.dumps(data))
    assert _code(common) == 1

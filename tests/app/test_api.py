"""The public API (import tiltload): the same options, errors and metrics as the command; compare checks the case
first; docs/api.md's examples run; the example controller repository's suite passes, and fails with a report when its
controller changes."""

from __future__ import annotations

import json
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest
import tiltload as tl
from support import ROOT
from tiltload.master.app.cli import main

TILTLOAD = str(Path(sys.executable).parent / "tiltload")


def _cli(*argv: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([TILTLOAD, *argv], capture_output=True, text=True, cwd=cwd, timeout=600)


def test_the_namespace_is_small_and_loads_nothing_heavy():
    code = "import sys, tiltload; print(sorted(m for m in ('numpy', 'casadi', 'fmpy', 'pandas') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"
    assert set(tl.__all__) == {"B2BCase", "B2BSide", "BackToBack", "b2b", "PythonController",
                               "CampaignOptions", "CampaignResult", "Case", "Comparison", "FalsifyOptions", "FalsifyResult", "MetricRow",
                               "Result", "RunOptions", "SignalComparison", "Signals", "TiltloadError", "campaign", "check", "compare",
                               "compare_signals", "falsify", "open_log", "run", "save_baseline", "save_signal_baseline", "plant",
                               "design", "saturate", "choose", "dead_zone", "rate_limit"}
    assert all(getattr(tl, name) is not None for name in tl.__all__)


def test_the_api_holds_no_second_command_line():
    """The API builds objects and calls the core: no argv, no parser, no redirected stdout under master/app/api."""
    api = ROOT / "master" / "app" / "api"
    words = re.compile(r"argparse|redirect_stdout|to_argv|parse_args")
    assert [f"{f.name}:{n}" for f in sorted(api.glob("*.py")) for n, line in enumerate(f.read_text().splitlines(), 1)
            if words.search(line)] == []


# a wrong value: the keywords, and the command line that says the same (the CLI's line must be the exception's)
WRONG_VALUES = [({"seed": -1}, ["--seed=-1"]), ({"stop_time": -1}, ["--stop-time=-1"]), ({"scenario": "kalman"}, ["--scenario", "kalman"]),
                ({"vehicle": "uav", "scenario": "lkf"}, ["--vehicle", "uav", "--scenario", "lkf"]), ({"clocks": True}, ["--clocks"]),
                ({"set": {"plant": 1}}, ["--set", "plant=1"]), ({"fmi": 4}, ["--fmi", "4"]),
                ({"controller": "missing.fmu"}, ["--controller", "missing.fmu"]), ({"log_every": 0}, ["--log-every", "0"]),
                ({"snapshot_at": ("soon", "s.snap")}, ["--snapshot-at", "soon", "s.snap"])]


def _cli_error(argv: list[str], capsys) -> tuple[int, list[str]]:
    capsys.readouterr()
    try:
        code = main(["run", *argv, "--no-log", "--quiet"])
    except SystemExit as stop:  # the parser's own refusal
        code = stop.code
    return code, capsys.readouterr().err.strip().splitlines()


@pytest.mark.parametrize(("options", "argv"), WRONG_VALUES, ids=[" ".join(a) for _, a in WRONG_VALUES])
def test_a_wrong_value_is_one_tiltload_error_with_the_command_s_line(options, argv, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # nothing is written, and missing.fmu is missing
    with pytest.raises(tl.TiltloadError) as err:
        tl.run(no_log=True, **options)
    code, lines = _cli_error(argv, capsys)
    assert code == 2 and lines == [err.value.cli_line]
    assert str(err.value) in err.value.cli_line and "\n" not in err.value.cli_line


@pytest.mark.parametrize(("command", "call", "argv"), [
    ("campaign", lambda spec: tl.campaign(spec, workers=0), ["--workers", "0"]),
    ("campaign", lambda spec: tl.campaign(spec, tl.CampaignOptions(retries=101)), ["--retries", "101"]),
    ("falsify", lambda spec: tl.falsify(spec, simulations=0), ["--simulations", "0"]),
    ("falsify", lambda spec: tl.falsify(spec, tl.FalsifyOptions(optimizer="annealing")), ["--optimizer", "annealing"]),
])
def test_campaign_and_falsify_options_say_their_command_s_line(command, call, argv, tmp_path, capsys):
    spec = tmp_path / "spec.toml"  # never read: the options are refused first
    with pytest.raises(tl.TiltloadError) as err:
        call(spec)
    with pytest.raises(SystemExit) as stop:
        main([command, str(spec), *argv])
    assert stop.value.code == 2 and capsys.readouterr().err.strip().splitlines() == [err.value.cli_line]


def test_the_documented_line_of_a_seed_out_of_range():
    with pytest.raises(tl.TiltloadError) as err:
        tl.Case(seed=-1)
    assert err.value.cli_line == ("tiltload run: error: argument --seed: must be a whole number from 0 to 2147483647, got -1 "
                                  "(see: tiltload run --help)")


@pytest.mark.parametrize(("make", "field"), [
    (lambda: tl.Case(stop_time="soon"), "Case.stop_time"), (lambda: tl.Case(seed=1.5), "Case.seed"),
    (lambda: tl.Case(seed=True), "Case.seed"), (lambda: tl.Case(delay="yes"), "Case.delay"),
    (lambda: tl.Case(trajectory=[1]), "Case.trajectory"), (lambda: tl.Case(set={"plant.m_L": [0.2]}), "Case.set['plant.m_L']"),
    (lambda: tl.Case(set=["plant.m_L=0.2"]), "Case.set"), (lambda: tl.Case(fmus=3), "Case.fmus"),
    (lambda: tl.RunOptions(log_every="2"), "RunOptions.log_every"), (lambda: tl.RunOptions(no_plots=1), "RunOptions.no_plots"),
    (lambda: tl.run(stop_time="3"), "Case.stop_time"), (lambda: tl.CampaignOptions(workers="2"), "CampaignOptions.workers"),
    (lambda: tl.FalsifyOptions(simulations=4.0), "FalsifyOptions.simulations"),
])
def test_a_wrong_type_is_a_type_error_naming_the_field(make, field):
    with pytest.raises(TypeError) as err:
        make()
    assert str(err.value).startswith(f"{field} must be ") and "\n" not in str(err.value)


def test_an_unknown_keyword_is_named():
    with pytest.raises(TypeError, match=r"unexpected keyword argument 'stop_tme' \(did you mean 'stop_time'\?\)"):
        tl.run(stop_tme=3)
    with pytest.raises(TypeError, match="'stop'"):  # argparse would take --stop as --stop-time: the API does not
        tl.run(stop=3)
    with pytest.raises(TypeError, match="'simulation'"):
        tl.falsify("spec.toml", simulation=4)


def test_the_request_objects_are_frozen_and_say_their_command_line(tmp_path):
    from dataclasses import FrozenInstanceError

    case = tl.Case(scenario="lkf", trajectory=2, seed=3, stop_time=2.5, set={"plant.m_L": 0.2, "controller.x": True},
                   remote={"controller": "10.0.0.2:7390"})
    with pytest.raises(FrozenInstanceError):
        case.seed = 4  # type: ignore[misc]
    assert case.set == (("plant.m_L", 0.2), ("controller.x", True)) and case.stop_time == 2.5
    from tiltload.master.app.api.running import command_line

    line = command_line(case, tl.RunOptions(out=tmp_path / "my runs", no_plots=True, realtime=True))
    assert shlex.split(line) == ["tiltload", "run", "--scenario", "lkf", "--trajectory", "2", "--seed", "3", "--stop-time", "2.5",
                                 "--set", "plant.m_L=0.2", "--set", "controller.x=true", "--remote", "controller=10.0.0.2:7390",
                                 "--out", str(tmp_path / "my runs"), "--no-plots", "--realtime", "1"]
    # the command line read back by the command's own parser is the same case
    from tiltload.master.app.cli import parser
    from tiltload.master.app.commands.run import case_of

    assert case_of(parser().parse_args(shlex.split(line)[1:])) == case


def test_a_case_the_keywords_and_the_command_give_the_same_metrics_bit_for_bit(fmus, tmp_path, capsys):
    """tl.run(Case(...)), tl.run(**keywords) and `tiltload run` (the result's own command line, replayed) on 2 s of a case."""
    from tiltload.master.app.regression.compare import load_metrics

    case = tl.Case(scenario="fsi", controller="dlqr", stop_time=2, fmus=fmus)
    typed = tl.run(case, tl.RunOptions(out=tmp_path, no_plots=True))
    keywords = tl.run(scenario="fsi", controller="dlqr", stop_time=2, fmus=fmus, no_log=True)
    assert keywords.case == typed.case == case and keywords.log is None and keywords.options.no_log
    assert len(typed.metrics) == 8 and all(type(v) is float for v in typed.metrics.values())
    assert keywords.metrics == typed.metrics  # dict equality of floats: bit for bit
    argv = shlex.split(typed.command)
    assert argv[:2] == ["tiltload", "run"] and "--quiet" not in argv
    logged = load_metrics(typed.log)[0]
    typed.log.unlink()
    assert main([*argv[1:], "--quiet"]) == 0  # runnable as printed
    assert load_metrics(typed.log)[0] == logged == typed.metrics
    assert typed.record["scenario"] == "fsi" and float(typed.record["stop_time"]) == 2.0
    out = capsys.readouterr().out
    assert "running fsi_traj1_dlqr_seed1_t2s: 2 s of simulated time" in out and "running fsi_traj1_dlqr_seed1_t2s" in typed.transcript


def test_the_api_s_log_name_is_the_command_s(fmus, tmp_path, capsys):
    """The schedule is the Case's, the rest of what names a log the RunOptions': both reach the name as the command's do."""
    options = ["--scenario", "fsi", "--controller", "dlqr", "--stop-time", "0.5", "--schedule", "jacobi", "--log-every", "2"]
    assert main(["run", *options, "--fmus", str(fmus), "--out", str(tmp_path), "--no-plots", "--quiet"]) == 0
    command = [line for line in capsys.readouterr().out.splitlines() if line.startswith("running ")]
    result = tl.run(scenario="fsi", controller="dlqr", stop_time=0.5, schedule="jacobi", log_every=2, fmus=fmus, no_log=True)
    said = [line for line in result.transcript.splitlines() if line.startswith("running ")]
    assert said == command == ["running fsi_traj1_dlqr_seed1_t0.5s_jacobi_every2: 0.5 s of simulated time"]


def test_a_parameter_of_the_wrong_type_is_the_user_s_to_fix(fmus, tmp_path, capsys):
    """--set plant.m_L=abc: text for a Real is one line and exit 2 (it was "unexpected failure, a bug")."""
    with pytest.raises(tl.TiltloadError) as err:
        tl.run(set={"plant.m_L": "abc"}, stop_time=1, fmus=fmus, no_log=True)
    assert str(err.value) == "--set plant.m_L=abc: m_L is a Real parameter of plant, got text"
    code, lines = _cli_error(["--set", "plant.m_L=abc", "--stop-time", "1", "--fmus", str(fmus)], capsys)
    assert code == 2 and lines == [err.value.cli_line] == [f"tiltload: error: {err.value}"]


FALSIFY = """
name = "tiny"
optimizer = "uniform"
seed = 0
[base]
scenario = "fsi"
trajectory = 1
controller = "dlqr"
stop_time = 1.5
gusts = false
[[requirements]]
name = "swing"
formula = "always[0.5:1.5] (abs(plant.gamma_1) < 0.445)"
[[search]]
name = "gust_speed"
target = "gust.amplitude"
range = [0.0, 8.0]
[[search]]
name = "gust_start"
target = "gust.start"
range = [0.2, 1.0]
[budget]
simulations = 50
"""


@pytest.mark.slow
def test_falsify_returns_its_result(fmus, tmp_path):
    spec = tmp_path / "tiny.toml"
    spec.write_text(FALSIFY)
    found = tl.falsify(spec, simulations=4, workers=1, fmus=fmus, out=tmp_path / "out")
    assert isinstance(found, tl.FalsifyResult) and found.simulations == 4 and len(found.rows) == 4
    assert found.results.is_file() and len(found.to_dataframe()) == 4
    assert found.command == shlex.join(["tiltload", "falsify", str(spec), "--out", str(tmp_path / "out"), "--simulations", "4",
                                        "--workers", "1", "--fmus", str(fmus)])
    scored = [r["robustness"] for r in found.rows]
    assert found.robustness == min(scored) and found.falsified == (min(scored) < 0)
    html = found._repr_html_()  # in a notebook: the search's report (report.html's content), its best case judged
    assert html.startswith('<div class="tiltload-report">') and "<script" not in html
    failed = int(re.search(r'data-verdict="FAIL"><b>(\d+)</b>', html).group(1))
    assert (failed > 0) == found.falsified and "The search" in html


def _record(**changes) -> dict:
    from tiltload.master.app.case.record import record

    base = {"scenario": "zse", "trajectory": 1, "controller": "mixed", "seed": 1, "stop_time": 40.0}
    return {k: str(v) for k, v in record(**{**base, **changes}).items()}


def _baseline(path: Path, run: dict, metrics: dict) -> Path:
    path.write_text(json.dumps({"run": run, "metrics": metrics}))
    return path


def test_compare_says_in_one_line_what_differs_between_the_cases(tmp_path, capsys):
    metrics = {"ISE(x)": 1.0, "ISE(y)": 2.0}
    base = _baseline(tmp_path / "base.json", _record(), metrics)
    other = _baseline(tmp_path / "other.json", _record(seed=3, stop_time=5.0), {"ISE(x)": 7.0, "ISE(y)": 2.0})
    assert main(["compare", str(other), str(base)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "different cases (seed 3 vs 1; stop time 5 s vs 40 s)" in err[0] and "--any-case" in err[0]
    assert main(["compare", str(other), str(base), "--any-case"]) == 1  # compared: ISE(x) differs
    assert "ISE(x)" in capsys.readouterr().out
    for change, words in [({"wind": ROOT / "docs/examples/gusty_wind.yaml"}, "wind gusty_wind"), ({"settings": (("plant.m_L", 0.2),)},
                          "--set plant.m_L=0.2 vs none"), ({"controller": "/else/where/mine.fmu"}, "controller mine vs mixed"),
                          ({"faults": ROOT / "docs/faults/gps_dropout.json"}, "faults gps_dropout"), ({"schedule": "jacobi"},
                          "schedule jacobi vs ordered"), ({"trajectory": 2}, "trajectory 2 vs 1")]:
        changed = _baseline(tmp_path / "changed.json", _record(**change), metrics)
        with pytest.raises(tl.TiltloadError, match=re.escape(words)):
            tl.compare(changed, base)
    # the same controller FMU elsewhere is the same case; the same case compares its metrics
    moved = _baseline(tmp_path / "moved.json", _record(controller="/a/mine.fmu"), metrics)
    assert tl.compare(moved, _baseline(tmp_path / "mine.json", _record(controller="/b/mine.fmu"), metrics)).ok


def test_a_baseline_that_names_no_case_is_compared_with_a_note(tmp_path):
    base = tmp_path / "old.json"
    base.write_text(json.dumps({"metrics": {"ISE(x)": 1.0}}))
    result = tl.compare(_baseline(tmp_path / "run.json", _record(), {"ISE(x)": 1.0}), base)
    assert result.ok and result.notes == [f"{base} names no case: the case is not checked"]


CASES = [("fsi", 1, "dlqr"), ("lkf", 2, "mixed"), ("zse", 1, "mixed")]


@pytest.mark.parametrize("case", CASES, ids=["_".join(map(str, c)) for c in CASES])
@pytest.mark.slow
def test_the_api_s_metrics_are_the_command_s_bit_for_bit(case, fmus, tmp_path):
    """Reproduction cases (5 s of each): the command's log record and the API's Result hold the same floats."""
    scenario, trajectory, controller = case
    options = {"scenario": scenario, "trajectory": trajectory, "controller": controller, "stop_time": 5, "fmus": fmus,
               "no_plots": True}
    result = tl.run(out=tmp_path / "api", **options)
    from tiltload.master.app.regression.compare import load_metrics

    argv = shlex.split(result.command)[2:]
    argv[argv.index("--out") + 1] = str(tmp_path / "cli")
    cli = _cli("run", *argv, "--quiet", cwd=tmp_path)
    assert cli.returncode == 0, cli.stderr
    log = tmp_path / "cli" / result.log.name
    assert load_metrics(log)[0] == result.metrics  # dict equality of floats: bit for bit
    assert f"--scenario {scenario} --trajectory {trajectory} --controller {controller} --stop-time 5" in result.command
    assert tl.compare(result, log, rtol=0, atol=0).ok
    plant = result.signals("/plant")
    assert plant.time[0] == 0 and plant.time[-1] == pytest.approx(5, abs=0.012) and len(plant["x"]) == len(plant.time)
    frame = result.to_dataframe("/plant")
    assert list(frame["z"]) == list(plant["z"]) and frame.index.name == "t"


def _python_blocks(text: str) -> list[str]:
    return re.findall(r"```python\n(.*?)```", text, flags=re.S)


@pytest.mark.slow
def test_the_examples_of_docs_api_md_run(fmus, tmp_path, monkeypatch, capsys):
    blocks = _python_blocks((ROOT / "docs" / "api.md").read_text())
    script = blocks[1]
    assert len(script.strip().splitlines()) < 15  # the scripted regression run
    (tmp_path / "fmus").symlink_to(fmus)
    monkeypatch.chdir(tmp_path)
    for block in blocks:
        exec(compile(block, "docs/api.md", "exec"), {})
    out = capsys.readouterr().out
    assert "tiltload run --scenario lkf --controller dlqr --stop-time 3 --no-plots" in out and "same" not in out
    assert (tmp_path / "baselines" / "lkf_dlqr_3s.json").is_file()


@pytest.mark.slow
def test_the_example_repository_s_suite_passes_and_reports_a_changed_controller(fmus, tmp_path):
    from support import example_repo

    repo = example_repo.copy(tmp_path / "repo")
    passed = example_repo.run_suite(sys.executable, repo, fmus, tmp_path / "pass.xml")
    assert passed.returncode == 0, passed.stdout[-3000:]
    assert list(example_repo.outcomes(tmp_path / "pass.xml").values()) == [None, None, None]

    example_repo.regress(repo)
    page = tmp_path / "fail.html"
    failed = example_repo.run_suite(sys.executable, repo, fmus, tmp_path / "fail.xml", extra=(f"--tiltload-report={page}",))
    assert failed.returncode == 1
    results = example_repo.outcomes(tmp_path / "fail.xml")
    baseline_tests = [name for name in results if name.startswith("test_the_controller_matches_its_baseline")]
    assert len(results) == 3 and len(baseline_tests) == 2 and all(results[name] for name in baseline_tests), results
    message = results[baseline_tests[0]]
    for words in example_repo.REPORT_WORDS:
        assert words in message, message
    # the session's report: each test's baseline outcome; a failing one with its metric table (the metrics its
    # message names out of tolerance: DIFFERS), not only the message's first line
    data = json.loads(re.search(r'id="tiltload-results">(.*?)</script>', page.read_text(encoding="utf-8"), re.S).group(1))
    by_name = {t["name"].split("::")[-1]: t for t in data["tests"]}
    for name in baseline_tests:
        (checked,) = by_name[name]["baselines"]
        assert checked["what"] == "metrics" and checked["outcome"] == "FAIL" and checked["file"].startswith("baselines/")
        (table,) = checked["tables"]
        differ = [row[0] for row in table["rows"] if row[-1] != "ok"]
        said = re.search(r"(\d+) of (\d+) metrics out of tolerance", results[name])
        assert len(differ) == int(said.group(1)) and len(table["rows"]) == int(said.group(2))
        assert all(re.search(rf"\n\s+{re.escape(m)}\s+run ", results[name]) for m in differ)
    assert by_name["test_the_controller_tracks_the_circle_closely"]["baselines"] == []


CAMPAIGN = """
name = "api"
[base]
scenario = "fsi"
trajectory = 1
controllers = ["dlqr"]
stop_time = 1.5
[vary]
seeds = [1, 2]
"""


@pytest.mark.slow
def test_a_campaign_through_the_api(fmus, tmp_path, capsys):
    spec = tmp_path / "api.toml"
    spec.write_text(CAMPAIGN)
    done = tl.campaign(spec, out=tmp_path / "out", workers=1, fmus=fmus)
    assert done.command == f"tiltload campaign {spec} --out {tmp_path / 'out'} --workers 1 --fmus {fmus}"
    assert {k: done.counts[k] for k in ("total", "ran", "completed", "failed")} == {"total": 2, "ran": 2, "completed": 2, "failed": 0}
    table = done.to_dataframe()
    assert sorted(table["seed"]) == [1, 2]
    again = tl.campaign(spec, out=tmp_path / "out", workers=1, fmus=fmus)  # resumable: nothing left to run
    assert (again.counts["skipped"], again.counts["ran"]) == (2, 0)
    bad = tmp_path / "bad.toml"
    bad.write_text(CAMPAIGN.replace('scenario = "fsi"', 'scenario = "ekf"'))
    with pytest.raises(tl.TiltloadError) as err:
        tl.campaign(bad, out=tmp_path / "bad", fmus=fmus)
    capsys.readouterr()  # the campaigns' progress lines
    assert main(["campaign", str(bad), "--out", str(tmp_path / "bad"), "--fmus", str(fmus)]) == 2
    assert capsys.readouterr().err.strip() == err.value.cli_line


def test_a_changed_plant_is_said_to_run_the_nominal_controller(fmus, tmp_path):
    """--set of a plant parameter: one note that the controller stays the nominal design, and how to get another;
    none for a value equal to the nominal one, or for a controller parameter."""
    from tiltload.plant_fmu.vehicles import VEHICLES

    nominal = dict(zip((s.name for s in VEHICLES["load"].parameter_specs), VEHICLES["load"].default_parameters()))
    common = {"stop_time": 0.12, "fmus": fmus, "out": tmp_path, "no_plots": True}
    changed = tl.run(set={"plant.m_L": 0.2}, **common).transcript.splitlines()
    notes = [line for line in changed if "nominal design" in line]
    assert notes == ["note: --set plant.m_L=0.2 changes the plant only: the mixed controller, its estimator and the feedforward "
                     "stay the nominal design (Table 5.1's parameters); for a controller of the changed plant, design your own "
                     "on it, wrap it (tiltload wrap, docs/ports.md) and run it with --controller IT.fmu"]
    assert nominal["m_L"] != 0.2
    same = tl.run(set={"plant.m_L": nominal["m_L"]}, **common).transcript
    assert "nominal design" not in same


def _result(metrics: dict, **case) -> tl.Result:
    """A Result as tiltload.run returns it, without running (the plugin's paths on known numbers)."""
    return tl.Result(metrics=metrics, case=None, options=None, record=_record(**case), log=None, command="tiltload run --stop-time 40",
                     stop_time=40.0, sim_time=40.0, wall_time=1.0, ticks=3333)


def test_the_plugin_s_baseline_records_compares_and_reports(tmp_path):
    from tiltload.master.app.testing.plugin import Baseline

    path = tmp_path / "baselines" / "test_x.json"
    node = "tests/test_c.py::test_x"
    with pytest.raises(pytest.fail.Exception, match=re.escape(f"no baseline recorded for {node} ({path}): record it with "
                                                              f'pytest --tiltload-update-baselines "{node}"')):
        Baseline(path, False, node, 1e-6, 1e-12).check(_result({"ISE(x)": 0.5, "IADU(f_R)": 2.0}))
    Baseline(path, True, node, 1e-6, 1e-12).check(_result({"ISE(x)": 0.5, "IADU(f_R)": 2.0}))
    assert json.loads(path.read_text())["tolerances"] == {"rtol": 1e-6, "atol": 1e-12}
    check = Baseline(path, False, node, 1e-6, 1e-12).check
    check(_result({"ISE(x)": 0.5 * (1 + 0.9e-6), "IADU(f_R)": 2.0}))  # within rtol 1e-6
    with pytest.raises(pytest.fail.Exception) as failed:
        check(_result({"ISE(x)": 0.55, "IADU(f_R)": 2.0}))
    lines = str(failed.value).splitlines()
    assert lines[0] == "the run differs from its baseline: 1 of 2 metrics out of tolerance"
    assert lines[3].split() == ["ISE(x)", "run", "0.55", "baseline", "0.5", "change", "+0.05", "(+10", "%);", "allowed",
                                "+/-5e-07", "(rtol", "1e-06,", "atol", "1e-12)"]
    assert "within tolerance: IADU(f_R)" in lines[4] and lines[-2] == "  rerun:    tiltload run --stop-time 40"
    with pytest.raises(pytest.fail.Exception, match=r"different cases \(seed 2 vs 1\).*\n  rerun: .*\n  to record it again"):
        check(_result({"ISE(x)": 0.5, "IADU(f_R)": 2.0}, seed=2))


def test_the_marker_s_cases_are_every_combination_and_limits_are_reported():
    from tiltload.master.app.testing.plugin import case_id, cases
    from tiltload.testing import TiltloadAssertionError, assert_metrics_below

    combos = cases({"scenario": ["zse", "lkf"], "trajectory": [1, 2], "seed": [1, 2, 3], "stop_time": 3})
    assert len(combos) == 12 and len({case_id(c) for c in combos}) == 12
    assert combos[0] == {"scenario": "zse", "trajectory": 1, "seed": 1, "stop_time": 3}
    assert_metrics_below(_result({"ISE(x)": 0.04}), {"ISE(x)": 0.05})
    with pytest.raises(TiltloadAssertionError) as err:
        assert_metrics_below(_result({"ISE(x)": 0.06, "ISE(y)": 0.01}), {"ISE(x)": 0.05, "ISE(y)": 0.05, "ISE(z)": 1})
    lines = str(err.value).splitlines()
    assert lines[0] == "the run: 2 of 3 metrics above their limits"
    assert lines[2].split() == ["ISE(x)", "0.06", ">", "limit", "0.05", "(by", "0.01,", "20", "%)"]
    assert lines[3].split() == ["ISE(z)", "missing", "from", "the", "run"]


def test_requirements_through_the_api_are_the_command_s(fmus, tmp_path):
    """run(requirements=...) monitors online; tl.check re-reads the log; `tiltload check --json` gives the same verdicts
    and robustness bit for bit; a formula the run breaks is a FAIL whose first violation is where the signal crosses."""
    import numpy as np

    reqs = tmp_path / "reqs.yaml"
    reqs.write_text("requirements:\n"
                    "  - name: thrust\n    formula: always (controller.f_R >= 0 and controller.f_R <= 30)\n"
                    "  - name: x_close\n    formula: always (abs(plant.x - scenario.x_ref) < 0.2)\n")
    result = tl.run(scenario="fsi", controller="dlqr", stop_time=4, fmus=fmus, out=tmp_path, no_plots=True, requirements=reqs)
    assert result.verdicts == {"thrust": "PASS", "x_close": "FAIL"}
    offline = tl.check(result, reqs)
    cli = _cli("check", str(reqs), str(result.log), "--json", cwd=tmp_path)
    assert cli.returncode == 1, cli.stderr  # a FAIL
    shown = {r["name"]: r for r in json.loads(cli.stdout)["logs"][0]["results"]}
    for online, again in zip(result.requirements, offline):
        assert (online.name, online.verdict, online.robustness, online.first_violation) == \
               (again.name, again.verdict, again.robustness, again.first_violation)
        assert shown[again.name]["verdict"] == again.verdict and shown[again.name]["robustness"] == again.robustness
    x, ref = result.signals("/plant"), result.signals("/scenario")
    err = np.abs(x["x"] - np.interp(x.time, ref.time, ref["x_ref"]))
    fail = next(r for r in offline if r.name == "x_close")
    assert fail.robustness == pytest.approx(0.2 - err.max(), abs=1e-9)  # the definition: min over t of 0.2 - |e(t)|
    before = err[x.time < fail.first_violation]  # the load starts 0.3 m off in x: violated from t = 0
    assert (before.size == 0 or before.max() < 0.2) and err[np.searchsorted(x.time, fail.first_violation)] >= 0.2
    with pytest.raises(tl.TiltloadError, match="did you mean"):
        tl.check(result, formulas=["bad: always plant.xx > 0"])


def test_runs_on_a_pool_restart_its_execution_and_equal_fresh_runs(fmus, tmp_path):
    """tl.run(..., pool=): the pytest plugin's session pool. Two runs of one loop structure share one execution (the
    second restarts it) and give the fresh run's metrics bit for bit; another controller FMU is another structure."""
    from tiltload.master.engine.lifecycle import ExecutionPool

    common = {"scenario": "fsi", "stop_time": 1.2, "fmus": fmus, "out": tmp_path, "no_log": True}
    fresh = tl.run(controller="dlqr", seed=3, **common)
    pool = ExecutionPool()
    try:
        first = tl.run(controller="dlqr", seed=3, pool=pool, **common)
        again = tl.run(controller="dlqr", seed=3, pool=pool, **common)
        assert len(pool) == 1
        assert first.metrics == again.metrics == fresh.metrics
    finally:
        pool.close()


@pytest.mark.parametrize("stop", [1e300, 1e6 + 1, float("inf")])
def test_a_stop_time_past_the_longest_run_is_refused_before_anything_runs(stop, tmp_path, capsys):
    """The feasibility check and the log are sized by the stop time: past 1e6 s it is refused in one line (it used to
    iterate without end, deaf to SIGTERM)."""
    with pytest.raises(tl.TiltloadError, match="at most 1e\\+06"):
        tl.run(stop_time=stop, no_plots=True, out=tmp_path)
    with pytest.raises(SystemExit) as cli:  # argparse's usage error
        main(["run", "--stop-time", repr(stop), "--out", str(tmp_path)])
    assert cli.value.code == 2
    said = capsys.readouterr().err.strip().splitlines()
    assert len(said) == 1 and "--stop-time: must be a positive time in s, at most 1e+06" in said[0]

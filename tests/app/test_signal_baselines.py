"""Signal baselines and what changed (docs/back_to_back.md): real short runs of the loop, one with a controller
parameter changed by --set; `tiltload compare`, tl.compare_signals and the pytest plugin's baseline say what changed
first, then the signals in their tubes; bad input is one line and exit 2."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import tiltload as tl
from tiltload.master.app.cli import main
from tiltload.master.app.regression import signal_baseline
from tiltload.master.app.regression.signal_compare import Tolerances, compare_signals
from tiltload.master.engine.tubes import Tolerance

CHANGED = "what changed: controller parameter x_0 1.7 -> 1.75; scenario, sensors and plant unchanged"
SIGNALS = ["plant.x", "plant.z", "controller.f_R"]


@pytest.fixture(scope="module")
def runs(fmus, tmp_path_factory) -> dict[str, tl.Result]:
    out = tmp_path_factory.mktemp("runs")
    common = {"scenario": "lkf", "stop_time": 0.6, "fmus": fmus, "out": out, "no_plots": True}
    return {"base": tl.run(name="base", **common), "again": tl.run(name="again", **common),
            "changed": tl.run(name="changed", set={"controller.x_0": 1.75}, **common),
            "short": tl.run(name="short", **{**common, "stop_time": 0.3})}


def _first_outside(ref: tl.Signals, run: tl.Signals, name: str, absolute: float) -> float | None:
    """On the logs' common grid with no time tolerance, the first time |run - ref| > absolute, by numpy alone."""
    assert np.array_equal(ref.time, run.time)
    out = np.abs(run[name] - ref[name]) > absolute
    return float(ref.time[np.argmax(out)]) if out.any() else None


def test_a_changed_controller_parameter_is_said_first_by_compare(runs, capsys):
    base, changed = runs["base"].log, runs["changed"].log
    assert main(["compare", str(changed), str(base)]) == 1  # the metrics; --set of the controller is not another case
    out = capsys.readouterr().out.splitlines()
    assert out[0] == CHANGED and out[-1].startswith("DIFFERENT")
    assert main(["compare", str(runs["again"].log), str(base)]) == 0  # the same FMUs and parameters: nothing said
    assert not capsys.readouterr().out.startswith("what changed")


def test_a_signal_baseline_passes_the_same_run_and_reports_the_changed_one(runs, tmp_path, capsys):
    path = tl.save_signal_baseline(runs["base"], tmp_path / "base.parquet", SIGNALS,
                                   tolerances={"default": {"abs": 1e-4}, "signals": {"plant.z": {"abs": 1e-3}}})
    header, stored = signal_baseline.read(path)
    ref = runs["base"].signals("/plant")
    np.testing.assert_array_equal(stored["plant.x"][0], ref.time)
    np.testing.assert_array_equal(stored["plant.x"][1], ref["x"])
    assert header["units"]["plant.x"] == "m" and header["fmus"]["controller.param.x_0"] == "1.7"

    assert tl.compare_signals(runs["again"], path).ok
    comparison = tl.compare_signals(runs["changed"], path)
    assert not comparison.ok and comparison.changed_line() == CHANGED
    row = {r.signal: r for r in comparison.rows}["plant.x"]
    assert row.first_outside == _first_outside(ref, runs["changed"].signals("/plant"), "x", 1e-4)
    assert row.tolerance.absolute == 1e-4  # the baseline's recorded tolerance; a given one replaces them all:
    assert tl.compare_signals(runs["changed"], path, tolerances={"default": {"abs": 1.0}}).ok
    assert not tl.compare_signals(runs["changed"], path, tolerances={"default": {"abs": 1.0}}, abs=1e-4).ok
    report = comparison.report(path, runs["changed"].command).splitlines()
    assert report[0] == f"the run differs from its signal baseline; {CHANGED}"
    assert any(line.split()[:6] == ["plant.x", "first", "outside", "at", "t", "="] for line in report)

    figures = tmp_path / "figures"
    assert main(["compare", str(runs["changed"].log), str(path), "--figures", str(figures)]) == 1
    out = capsys.readouterr().out.splitlines()
    assert out[0] == CHANGED and any(line.split()[:2] == ["plant.x", "OUTSIDE"] for line in out)
    assert (figures / "changed_tube_plant.x.png").stat().st_size > 10_000


def test_the_plugin_names_the_changed_parameter_first(runs, tmp_path):
    from tiltload.master.app.testing.plugin import Baseline

    node = "tests/test_c.py::test_x"
    path = tmp_path / "baselines" / "test_x.json"
    Baseline(path, True, node, 1e-6, 1e-12).check(runs["base"])
    Baseline(path, True, node, 1e-6, 1e-12).check_signals(runs["base"], SIGNALS, abs=1e-4)
    check = Baseline(path, False, node, 1e-6, 1e-12)
    check.check(runs["again"])
    check.check_signals(runs["again"], SIGNALS, abs=1e-4)
    for assertion in (lambda: check.check(runs["changed"]), lambda: check.check_signals(runs["changed"], SIGNALS, abs=1e-4)):
        with pytest.raises(pytest.fail.Exception) as failed:
            assertion()
        first = str(failed.value).splitlines()[0]
        assert first.startswith("the run differs from its") and first.endswith(CHANGED), first


def test_a_run_that_ends_early_is_outside_from_its_end(runs):
    path = runs["base"].log
    with pytest.raises(tl.TiltloadError, match=r"different cases \(stop time 0.3 s vs 0.6 s\)"):
        tl.compare_signals(runs["short"], path, signals=["plant.x"])
    short = tl.compare_signals(runs["short"], path, signals=["plant.x"], any_case=True).rows[0]
    end = runs["short"].signals("/plant").time[-1]
    times = runs["base"].signals("/plant").time
    assert not short.passed and short.first_outside == times[times > end][0]
    assert short.largest_excess == math.inf and "a NaN, infinite or missing value" in short.words()


def test_a_run_longer_than_its_baseline_says_its_tail_is_not_compared(runs):
    """Tubes are judged over the baseline's span: the run past the short baseline's end is named as not compared."""
    longer = tl.compare_signals(runs["base"], runs["short"].log, signals=["plant.x"], any_case=True)
    assert longer.ok  # the same run up to the short one's end
    end, base_end = runs["base"].signals("/plant").time[-1], runs["short"].signals("/plant").time[-1]
    assert [n for n in longer.notes if "not compared there" in n] == [
        f"the run goes on to t = {end:.6g} s, past the baseline's end at t = {base_end:.6g} s: not compared there "
        "(tubes are judged over the baseline's span)"]
    same = tl.compare_signals(runs["again"], runs["base"].log, signals=["plant.x"])
    assert not [n for n in same.notes if "not compared" in n]


def test_a_diverging_candidate_is_reported_from_its_first_nan_not_raised(tmp_path):
    t = np.linspace(0, 1, 101)
    ref = {"plant.x": (t, np.sin(t))}
    run_y = np.sin(t)
    run_y[40:] = np.where(np.arange(61) % 2, np.inf, np.nan)
    row = compare_signals({"plant.x": (t, run_y)}, ref, Tolerances(Tolerance(absolute=1e-3)), {"plant.x": "m"})[0]
    assert not row.passed and row.first_outside == t[40] and row.share_outside == pytest.approx(0.6)
    from tiltload.master.app.regression.tube_plot import tube_figures

    assert [p.name for p in tube_figures([row], tmp_path, "diverged")] == ["diverged_tube_plant.x.png"]  # drawn, not raised


TOML_BAD = {
    "negative": ('[default]\nabs = -1\n', "tol.toml: default: abs = -1 must be a finite number >= 0"),
    "infinite": ('[signals."plant.x"]\nlag = inf\n', "tol.toml: signals.plant.x.lag: inf is not a finite number"),
    "unknown signal": ('[signals."plant.q"]\nabs = 1\n', "tol.toml: plant.q names no signal of"),
    "unknown key": ('[default]\nabsolute = 1\n', "tol.toml: default: unknown tolerance 'absolute' (abs, rel, lead, lag)"),
    "not instance.variable": ('[signals.x]\nabs = 1\n', "tol.toml: signal 'x' is not named instance.variable"),
}


@pytest.mark.parametrize("case", TOML_BAD)
def test_bad_tolerance_files_are_one_line_and_exit_2(case, runs, tmp_path, capsys):
    text, words = TOML_BAD[case]
    path = tmp_path / "base.parquet"
    tl.save_signal_baseline(runs["base"], path, SIGNALS)
    (tmp_path / "tol.toml").write_text(text)
    assert main(["compare", str(runs["again"].log), str(path), "--tolerances", str(tmp_path / "tol.toml")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and words in err.replace(str(tmp_path) + "/", ""), err


@pytest.mark.parametrize(("extra", "words"), [
    (["--abs", "-1"], "argument --abs: must be a finite number >= 0"),
    (["--lag", "nan"], "argument --lag: must be a finite number >= 0"),
    (["--signals", "plant.q"], "base.mcap has no signal plant.q (plant logs x, y, z"),
    (["--signals", "wing.x"], "base.mcap logs no instance 'wing': wing.x names no logged signal"),
    (["--signals", "plant"], "--signals: signal 'plant' is not named instance.variable"),
    (["--abs", "1", "--rtol", "1"], "--requirements, --rtol and --atol compare metrics"),
])
def test_bad_signal_options_are_one_line_and_exit_2(extra, words, runs, capsys):
    try:
        code = main(["compare", str(runs["again"].log), str(runs["base"].log), *extra])
    except SystemExit as done:  # the parser's own refusal
        code = done.code
    assert code == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and words in err, err


def test_a_log_baseline_needs_signals_and_a_baseline_of_another_case_is_refused(runs, tmp_path, capsys):
    assert main(["compare", str(runs["again"].log), str(runs["base"].log), "--abs", "1"]) == 2
    assert "name the signals to compare" in capsys.readouterr().err
    header, stored = signal_baseline.read(tl.save_signal_baseline(runs["base"], tmp_path / "b.parquet", SIGNALS))
    other = signal_baseline.write(tmp_path / "seed2.parquet", stored, {**header, "run": {**header["run"], "seed": "2"}})
    assert main(["compare", str(runs["again"].log), str(other)]) == 2
    err = capsys.readouterr().err.strip()
    assert "are different cases (seed 1 vs 2)" in err and "--any-case" in err
    assert main(["compare", str(runs["again"].log), str(other), "--any-case"]) == 0
    (tmp_path / "junk.parquet").write_bytes(b"PAR1 not really")
    assert main(["compare", str(runs["again"].log), str(tmp_path / "junk.parquet")]) == 2
    assert "is not a signal baseline" in capsys.readouterr().err


def _fmu(path: Path, guid: str, date: str, code: bytes) -> Path:
    import zipfile

    with zipfile.ZipFile(path, "w") as z:
        z.writestr("modelDescription.xml", f'<fmiModelDescription guid="{guid}" generationDateAndTime="{date}"/>')
        z.writestr("resources/controller.py", code)
    return path


def test_a_rewrapped_fmu_is_the_same_content_and_what_changed_is_told_in_order(tmp_path):
    from tiltload.master.app.regression.changes import what_changed
    from tiltload.master.engine.log.provenance import content_digest, fmu_digest

    one = _fmu(tmp_path / "a.fmu", "g1", "2026-12-04T14:41:58", b"kp = 1.0")
    again = _fmu(tmp_path / "b.fmu", "g2", "2026-12-04T14:42:03", b"kp = 1.0")  # a wrap stamps a new GUID and date
    edited = _fmu(tmp_path / "c.fmu", "g3", "2026-12-04T14:42:09", b"kp = 1.5")
    assert fmu_digest(one) != fmu_digest(again) and content_digest(one) == content_digest(again) != content_digest(edited)

    def record(fmu: Path, guid: str, **params: str) -> dict[str, str]:
        rec = {}
        for name in ("scenario", "plant", "controller"):
            path = fmu if name == "controller" else tmp_path / "a.fmu"
            rec.update({f"{name}.fmu": path.name, f"{name}.sha256": fmu_digest(path), f"{name}.content": content_digest(path),
                        f"{name}.model": name.title(), f"{name}.guid": guid if name == "controller" else "g"})
        return {**rec, **{f"controller.param.{k}": v for k, v in params.items()}}

    base = record(one, "g1", kp="1.0", ki="0.1")
    assert what_changed(base, record(again, "g2", kp="1.0", ki="0.1")) == []
    assert what_changed(base, record(one, "g1", kp="1.5", ki="0.1")) == ["controller parameter kp 1.0 -> 1.5",
                                                                          "scenario and plant unchanged"]
    changed = what_changed(base, record(edited, "g3", kp="1.0", ki="0.1", kd="2"))
    assert changed[0] == "controller parameter kd unset -> 2"  # the parameters first, then the FMU they came with
    assert changed[1] == f"controller FMU's content changed (a.fmu -> c.fmu, sha256 {fmu_digest(one)[:12]} -> {fmu_digest(edited)[:12]})"
    assert changed[2:] == ["scenario and plant unchanged"]
    assert what_changed(base, None) == [] and what_changed({**base, "wind.fmu": "w.fmu"}, base)[0] == "wind removed"


def test_a_signal_comparison_shows_in_a_notebook_with_a_figure_per_signal_outside(runs):
    """compare_signals' verdict as a notebook shows it: a test (FAIL with a signal outside), a row per signal with its
    first time outside as numpy finds it, a tube figure per signal outside; no script."""
    names = ["plant.x", "plant.z"]
    found = tl.compare_signals(runs["changed"], runs["base"].log, signals=names, abs=1e-9, any_case=True)
    html = found._repr_html_()
    ref, run = runs["base"].signals("/plant"), runs["changed"].signals("/plant")
    outside = [n for n in names if _first_outside(ref, run, n.split(".")[1], 1e-9) is not None]
    assert outside  # the gain moved the plant: the test can fail
    assert 'data-verdict="FAIL"><b>1</b>' in html and "<script" not in html
    assert html.count("<td>OUTSIDE</td>") == len(outside) and html.count('<img alt="case0 tube') == len(outside)
    for n in outside:
        assert f"<td>{_first_outside(ref, run, n.split('.')[1], 1e-9):.6g}</td>" in html

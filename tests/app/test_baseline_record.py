"""`tiltload compare RUN BASELINE --record-baseline` (docs/back_to_back.md): a run's log recorded as a signal baseline
(.parquet) or a metrics baseline (.json), as the pytest plugin records them; the recorded samples are the log's, the
tolerances the ones given, and a later compare holds the same run and catches a changed one; misuse is one line."""

from __future__ import annotations

import json

import numpy as np
import pytest
import tiltload as tl
from tiltload.master.app.cli import main
from tiltload.master.app.regression import signal_baseline


@pytest.fixture(scope="module")
def runs(fmus, tmp_path_factory) -> dict[str, tl.Result]:
    out = tmp_path_factory.mktemp("runs")
    common = {"scenario": "lkf", "stop_time": 0.4, "fmus": fmus, "out": out, "no_plots": True}
    return {"base": tl.run(name="base", **common), "again": tl.run(name="again", **common),
            "changed": tl.run(name="changed", set={"controller.x_0": 1.75}, **common)}


def test_a_signal_baseline_recorded_from_the_command_line(runs, tmp_path, capsys):
    path = tmp_path / "base.parquet"
    code = main(["compare", str(runs["base"].log), str(path), "--record-baseline", "--signals", "plant.x,controller.f_R",
                 "--abs", "1e-4", "--lag", "0.012"])
    assert code == 0 and capsys.readouterr().out.startswith(f"recorded {path}: 2 signals")
    header, stored = signal_baseline.read(path)
    plant, controller = runs["base"].signals("/plant"), runs["base"].signals("/controller")
    np.testing.assert_array_equal(stored["plant.x"][0], plant.time)
    np.testing.assert_array_equal(stored["plant.x"][1], plant["x"])
    np.testing.assert_array_equal(stored["controller.f_R"][1], controller["f_R"])
    assert header["tolerances"]["default"] == {"abs": 1e-4, "rel": 1e-6, "lead": 0.0, "lag": 0.012}
    assert header["run"]["scenario"] == "lkf" and header["fmus"]["controller.param.x_0"] == "1.7"
    assert main(["compare", str(runs["again"].log), str(path)]) == 0
    capsys.readouterr()
    assert main(["compare", str(runs["changed"].log), str(path)]) == 1
    assert capsys.readouterr().out.startswith("what changed: controller parameter x_0 1.7 -> 1.75")


def test_a_metrics_baseline_recorded_from_the_command_line(runs, tmp_path, capsys):
    path = tmp_path / "base.json"
    assert main(["compare", str(runs["base"].log), str(path), "--record-baseline", "--rtol", "1e-9"]) == 0
    data = json.loads(path.read_text())
    assert data["metrics"] == pytest.approx(runs["base"].metrics, rel=0, abs=0)
    assert data["tolerances"] == {"rtol": 1e-9, "atol": 1e-12} and data["run"]["scenario"] == "lkf"
    capsys.readouterr()
    assert main(["compare", str(runs["again"].log), str(path)]) == 0
    assert main(["compare", str(runs["changed"].log), str(path)]) == 1


@pytest.mark.parametrize(("target", "extra", "words"), [
    ("b.parquet", [], "name the signals to record"),
    ("b.parquet", ["--signals", "plant.x", "--rtol", "1e-3"], "--rtol and --atol are the metrics' tolerances"),
    ("b.json", ["--signals", "plant.x"], "a metrics baseline (.json) records the metrics"),
    ("b.csv", [], "a baseline is a signal baseline (.parquet) or a metrics baseline (.json)"),
    ("b.parquet", ["--signals", "plant.q"], "has no signal plant.q"),
])
def test_recording_misuse_is_one_line(target, extra, words, runs, tmp_path, capsys):
    try:
        code = main(["compare", str(runs["base"].log), str(tmp_path / target), "--record-baseline", *extra])
    except SystemExit as done:
        code = done.code
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and words in err, err

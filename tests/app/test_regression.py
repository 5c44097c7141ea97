"""Reproduction and regression: the committed baselines hold; compare catches differences and refuses bad input."""

from __future__ import annotations

import json

import pytest
from support import ROOT
from tiltload.master.app.cli import main
from tiltload.master.app.regression.reproduce import run_case, tables
from tiltload.master.app.regression.thesis_values import METRICS


@pytest.mark.parametrize("case", [("fsi", 1, "mixed"), ("lkf", 2, "dlqr")])
@pytest.mark.slow
def test_committed_baselines_hold(fmus, tmp_path, case, capsys):
    """Two of the twelve cases, full length, against baselines/ with their own tolerance."""
    r = run_case(str(fmus), str(tmp_path), *case, None)
    assert r["error"] is None
    code = main(["compare", r["log"], str(ROOT / "baselines" / f"{r['case']}.json")])
    out = capsys.readouterr().out
    assert code == 0, out


def test_compare_passes_an_identical_run_and_catches_a_perturbed_one(fmus, tmp_path, capsys):
    args = ["run", "--scenario", "fsi", "--stop-time", "3", "--fmus", str(fmus), "--quiet", "--no-plots"]
    assert main([*args, "--out", str(tmp_path / "a")]) == 0
    assert main([*args, "--out", str(tmp_path / "b")]) == 0
    assert main([*args, "--out", str(tmp_path / "c"), "--controller", "dlqr"]) == 0  # a changed design
    capsys.readouterr()
    a, b, c = (next((tmp_path / d).glob("*.mcap")) for d in "abc")
    assert main(["compare", str(b), str(a)]) == 0
    assert "same within tolerance" in capsys.readouterr().out
    assert main(["compare", str(c), str(a)]) == 2  # another case: said in one line, not compared
    assert "different cases (controller dlqr vs mixed)" in capsys.readouterr().err
    assert main(["compare", str(c), str(a), "--any-case"]) == 1
    out = capsys.readouterr().out
    assert "DIFFERS" in out and "ISE(x)" in out
    base = tmp_path / "loose.json"  # a metrics file with its own, per-metric tolerance
    metrics = json.loads((ROOT / "baselines" / "fsi_traj1_mixed.json").read_text())["metrics"]
    base.write_text(json.dumps({"metrics": {"ISE(x)": metrics["ISE(x)"]}, "tolerances": {"ISE(x)": {"rtol": 10.0}}}))
    assert main(["compare", str(a), str(base)]) == 0


def test_compare_refuses_bad_input(tmp_path, capsys):
    junk = tmp_path / "junk.mcap"
    junk.write_text("no")
    assert main(["compare", str(junk), str(tmp_path / "missing.json")]) == 2
    assert "is not a readable MCAP log" in capsys.readouterr().err


def test_tables_put_the_thesis_side_by_side():
    fake = [{"scenario": s, "trajectory": 1, "controller": c, "error": None,
             "metrics": dict.fromkeys(METRICS, 1.0)}
            for s in ("fsi", "lkf", "zse") for c in ("dlqr", "mixed")]
    md = tables(fake)
    assert "thesis Table 5.4" in md and "| ISE(x) | 1 | 0.1571 | 6.37 |" in md and "thesis Table 5.11" in md


@pytest.mark.parametrize("baseline, needle", [
    ({"metrics": {}}, "holds no metrics"),
    ({"metrics": {"ISE(x)": 0.1}, "tolerances": {"rtol": float("inf")}}, "tolerances.rtol: Infinity is not a finite number"),
    ({"metrics": {"ISE(x)": 0.1}, "tolerances": {"ISE(x)": {"atol": -1}}}, "tolerances.ISE(x).atol: -1 is less than the minimum of 0"),
    ({"metrics": {"ISE(x)": "abc"}}, "is not a metrics file"),
])
def test_compare_refuses_a_baseline_it_cannot_use(tmp_path, capsys, baseline, needle):
    path = tmp_path / "base.json"
    path.write_text(json.dumps(baseline))
    assert main(["compare", str(path), str(path)]) == 2
    assert needle in capsys.readouterr().err


@pytest.mark.parametrize("flag, value", [("--rtol", "nan"), ("--rtol", "-1"), ("--atol", "inf")])
def test_compare_refuses_bad_tolerances_as_usage_errors(tmp_path, capsys, flag, value):
    with pytest.raises(SystemExit) as exit_:
        main(["compare", "a.mcap", "b.json", flag, value])
    assert exit_.value.code == 2 and "must be a finite number >= 0" in capsys.readouterr().err

"""`tiltload b2b`: a case list run as a reference and as a candidate, compared signal by signal; the candidate's first
time outside checked by numpy on the two logs; bad case lists and sides are one line, exit 2."""

from __future__ import annotations

import numpy as np
import pytest
from tiltload.master.app.cli import main
from tiltload.master.app.regression.back_to_back import SIGNALS
from tiltload.master.engine.log.reader import read_columns

CASES = 'cases = [{scenario = "lkf", trajectory = 1}, {scenario = "fsi", trajectory = 2, controller = "mixed"}]\n'


def _first_outside(ref_log, cand_log, absolute: float, relative: float) -> float | None:
    """The first time any of the signals leaves |cand - ref| <= max(abs, rel |ref|) (same grid, no time tolerance)."""
    ref, _ = read_columns(ref_log)
    cand, _ = read_columns(cand_log)
    first = []
    for name in SIGNALS:
        topic, variable = "/" + name.split(".")[0], name.split(".")[1]
        (t, r), (tc, c) = (ref[topic][0], ref[topic][1][variable]), (cand[topic][0], cand[topic][1][variable])
        assert np.array_equal(t, tc)
        out = np.abs(c - r) > np.maximum(absolute, relative * np.abs(r))
        first += [t[np.argmax(out)]] if out.any() else []
    return min(first) if first else None


def test_a_changed_controller_parameter_is_caught_where_it_first_shows(fmus, tmp_path, capsys):
    (tmp_path / "cases.toml").write_text(CASES)
    out = tmp_path / "b2b"
    code = main(["b2b", "--cases", str(tmp_path / "cases.toml"), "--reference-fmus", str(fmus), "--candidate-fmus", str(fmus),
                 "--candidate-set", "controller.x_0=1.75", "--stop-time", "0.3", "--out", str(out), "--abs", "1e-4"])
    lines = capsys.readouterr().out.splitlines()
    assert code == 1, lines
    assert "what changed: controller parameter x_0 1.7 -> 1.75; scenario, sensors and plant unchanged" in lines
    lkf = next(line.split() for line in lines if line.startswith("lkf_traj1_dlqr "))
    first = _first_outside(out / "lkf_traj1_dlqr_reference.mcap", out / "lkf_traj1_dlqr_candidate.mcap", 1e-4, 1e-6)
    assert first is not None and float(lkf[3]) == pytest.approx(first, abs=1e-9)
    fsi = next(line.split() for line in lines if line.startswith("fsi_traj2_mixed "))
    assert fsi[1] == "8/8"  # the exact state: the estimator's initial load position is not used
    assert _first_outside(out / "fsi_traj2_mixed_reference.mcap", out / "fsi_traj2_mixed_candidate.mcap", 1e-4, 1e-6) is None


@pytest.mark.parametrize(("text", "extra", "words"), [
    ('cases = [{scenario = "ekf", trajectory = 1}]\n', [], "is not a case list: cases.0.scenario"),
    ("cases = []\n", [], "is not a case list: cases"),
    (CASES, ["--candidate-controller", "nope.fmu"], "controller nope.fmu does not exist"),
    (CASES, ["--candidate-set", "x_0"], "argument --candidate-set: must be INSTANCE.NAME=VALUE"),
    (CASES, ["--abs", "-1"], "argument --abs: must be a finite number >= 0"),
])
def test_bad_case_lists_and_sides_are_one_line(text, extra, words, fmus, tmp_path, capsys):
    (tmp_path / "cases.toml").write_text(text)
    try:
        code = main(["b2b", "--cases", str(tmp_path / "cases.toml"), "--reference-fmus", str(fmus), "--candidate-fmus", str(fmus),
                     "--stop-time", "0.1", "--out", str(tmp_path / "b2b"), *extra])
    except SystemExit as done:
        code = done.code
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and words in err, err


def test_a_tolerance_for_a_signal_not_compared_is_refused_before_anything_runs(fmus, tmp_path, capsys):
    """A typo in a tolerance file would go unnoticed: refused in one line (exit 2) before a run is made."""
    from tiltload.master.app.cli import main

    tolerances = tmp_path / "tol.toml"
    tolerances.write_text('[signals."plant.nothing"]\nabs = 1\n')
    out = tmp_path / "b2b"
    code = main(["b2b", "--signals", "plant.x", "--tolerances", str(tolerances), "--reference-fmus", str(fmus),
                 "--candidate-fmus", str(fmus), "--out", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "plant.nothing" in err[0] and "not among the compared signals" in err[0]
    assert not out.exists() or not list(out.glob("*.mcap"))

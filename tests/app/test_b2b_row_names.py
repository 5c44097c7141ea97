"""Issue 61: `b2b` names a case's row by what its sides ran. Both sides running a user's controller FMU, the case
file's controller (dlqr by default) ran on neither: the row, its logs and the API's result say the two FMUs."""

from __future__ import annotations

import re
import shutil
import zipfile

import pytest
import tiltload as tl
from tiltload.master.app.cli import main

CASES = 'cases = [{scenario = "fsi", trajectory = 1}]\n'  # its controller: dlqr, by default


@pytest.fixture
def two_builds(fmus, tmp_path):
    """Two controller FMUs of a user's (our controller's build, the second with another file's bytes)."""
    mine, theirs = tmp_path / "mine.fmu", tmp_path / "theirs.fmu"
    shutil.copy(fmus / "TiltloadController.fmu", mine)
    shutil.copy(fmus / "TiltloadController.fmu", theirs)
    with zipfile.ZipFile(theirs, "a") as z:
        z.comment = b"another build"
    return mine, theirs


def test_b2b_rows_are_named_by_the_sides_in_the_table_the_logs_and_the_api(fmus, tmp_path, capsys, two_builds):
    mine, theirs = two_builds
    (tmp_path / "cases.toml").write_text(CASES)
    out = tmp_path / "cli"
    code = main(["b2b", "--cases", str(tmp_path / "cases.toml"), "--reference-fmus", str(fmus), "--candidate-fmus",
                 str(fmus), "--reference-controller", str(mine), "--candidate-controller", str(theirs),
                 "--stop-time", "0.3", "--out", str(out)])
    lines = capsys.readouterr().out.splitlines()
    assert code == 0, lines  # the same controller: the same signals
    rows = [line.split()[0] for line in lines[lines.index(next(x for x in lines if x.startswith("case "))) + 1:]
            if line and not line.startswith(("same", "DIFFERENT", " "))]
    assert rows == ["fsi_traj1_mine_vs_theirs"] and not any("dlqr" in line for line in lines)
    assert {p.name for p in out.glob("*.mcap")} == {"fsi_traj1_mine_vs_theirs_reference.mcap",
                                                    "fsi_traj1_mine_vs_theirs_candidate.mcap"}

    api = tl.b2b([{"scenario": "fsi", "trajectory": 1}], reference={"fmus": fmus, "controller": str(mine)},
                 candidate={"fmus": fmus, "controller": str(theirs)}, stop_time=0.3, out=tmp_path / "api")
    assert [r.name for r in api.results] == rows and api.table().splitlines()[1].split()[0] == rows[0]


def test_a_row_keeps_the_case_s_name_when_neither_side_replaces_its_controller(fmus, tmp_path):
    api = tl.b2b([{"scenario": "fsi", "trajectory": 1, "controller": "mixed"}], reference={"fmus": fmus},
                 candidate={"fmus": fmus, "settings": (("controller.x_0", 1.75),)}, stop_time=0.3, out=tmp_path)
    assert [r.name for r in api.results] == ["fsi_traj1_mixed"]
    # in a notebook: the report of the comparison, a test per case, a row per signal, a tube figure per signal outside
    html, [case] = api._repr_html_(), api.results
    outside = [r.signal for r in case.rows if not r.passed]
    assert f'data-verdict="{"PASS" if case.ok else "FAIL"}"><b>1</b>' in html and "<script" not in html
    assert len(re.findall(r"<td>(?:OUTSIDE)</td>", html)) == len(outside)
    assert html.count('<img alt="case0 tube') == len(outside)

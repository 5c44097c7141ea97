"""Every report names the FMUs that ran (issue 61): the check report and the falsification report read them from the
record their logs carry (case/record.py), as the run's own report reads them from its system; each SHA-256 is the file's
(an independent hash of the FMU), and two faces over the same log name the same FMUs."""

from __future__ import annotations

import hashlib
import json
import re
from pathlib import Path

import tiltload as tl
from tiltload.master.app.cli import main

ROOT = Path(__file__).resolve().parents[2]


def _page_data(path: Path) -> dict:
    found = re.search(r'<script type="application/json" id="tiltload-results">(.*?)</script>', path.read_text(), re.S)
    return json.loads(found.group(1).replace("<\\/", "</"))


def _named(data: dict) -> dict[str, str]:
    return {f["instance"]: f["sha256"] for f in data["environment"]["fmus"]}


def test_the_run_report_and_the_check_report_of_its_log_name_the_same_fmus(fmus, tmp_path):
    reqs = tmp_path / "reqs.yaml"
    reqs.write_text("requirements:\n  - name: thrust\n    formula: always (controller.f_R >= 0 and controller.f_R <= 30)\n")
    run_page, check_page = tmp_path / "run.html", tmp_path / "check.html"
    result = tl.run(scenario="fsi", stop_time=1, fmus=fmus, out=tmp_path, no_plots=True, requirements=reqs, report=run_page)
    assert main(["check", str(reqs), str(result.log), "--report", str(check_page)]) == 0
    ran, checked = _named(_page_data(run_page)), _named(_page_data(check_page))
    assert ran == checked and set(checked) == {"plant", "sensors", "scenario", "controller"}
    for record in result.fmus:
        assert checked[record.instance] == hashlib.sha256((fmus / record.path).read_bytes()).hexdigest()
    assert "No FMU record" not in check_page.read_text()


def test_a_falsification_report_names_the_controller_build_it_falsified(fmus, tmp_path):
    out = tmp_path / "search"
    tl.falsify(ROOT / "docs" / "falsification" / "altitude_thrust_loss.toml", out=out, simulations=4, fmus=fmus,
               branch="off", workers=1)
    named = _named(_page_data(out / "report.html"))
    assert named["controller"] == hashlib.sha256((fmus / "TiltloadController.fmu").read_bytes()).hexdigest()


def test_logs_of_runs_on_the_same_fmus_name_them_once_and_each_test_agrees(fmus, tmp_path):
    """Two logs of runs on the same FMUs (two seeds): the report's environment lists the FMUs once, and each test's own
    record (read from its log) names the same."""
    logs = []
    for seed in (1, 2):
        logs.append(tl.run(scenario="fsi", stop_time=0.5, seed=seed, fmus=fmus, out=tmp_path, no_plots=True).log)
    reqs = tmp_path / "reqs.yaml"
    reqs.write_text("requirements:\n  - name: thrust\n    formula: always (controller.f_R >= 0)\n")
    page = tmp_path / "check.html"
    assert main(["check", str(reqs), *map(str, logs), "--report", str(page)]) == 0
    data = _page_data(page)
    assert set(_named(data)) == {"plant", "sensors", "scenario", "controller"}
    assert all(t["environment"]["fmus"] == data["environment"]["fmus"] for t in data["tests"])

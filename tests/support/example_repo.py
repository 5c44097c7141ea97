"""The example controller repository (docs/examples/controller_repo) run by pytest with a given Python: its suite as
written, or after a regression of its controller (another gain than its baselines were recorded with)."""

from __future__ import annotations

import os
import shutil
import subprocess
import xml.etree.ElementTree as ET
from pathlib import Path

from . import ROOT

EXAMPLE = ROOT / "docs" / "examples" / "controller_repo"


def copy(dest: Path) -> Path:
    return shutil.copytree(EXAMPLE, dest)


def regress(repo: Path) -> None:
    """The controller's position weight 10 becomes 3: every metric of its baselines moves."""
    controller = repo / "controller" / "hover_lqr.py"
    text = controller.read_text()
    assert text.count("10.0") == 2  # the parameter's default and __init__'s
    controller.write_text(text.replace("10.0", "3.0"))


def run_suite(python: Path | str, repo: Path, fmus: Path, junit: Path, env: dict | None = None,
              extra: tuple[str, ...] = ()) -> subprocess.CompletedProcess:
    env = {k: v for k, v in (env or os.environ).items() if k != "PYTEST_ADDOPTS"}
    return subprocess.run([str(python), "-m", "pytest", "-q", "-p", "no:cacheprovider", f"--tiltload-fmus={fmus}",
                           f"--junitxml={junit}", *extra, "tests"], capture_output=True, text=True, cwd=repo, env=env, timeout=1800)


def outcomes(junit: Path) -> dict[str, str | None]:
    """Each test case's failure message (None: passed) from pytest's JUnit XML."""
    suite = ET.parse(junit).getroot().find("testsuite")
    out = {}
    for case in suite.iter("testcase"):
        failure = case.find("failure")
        assert case.find("error") is None and case.find("skipped") is None, ET.tostring(case)
        # the element's text is the whole report (pytest >= 9.2 cuts the message attribute to its first lines)
        out[case.get("name")] = None if failure is None else (failure.text or failure.get("message"))
    return out


# what the failure of a baseline test says (docs/api.md): which metrics, by how much, the tolerance, the rerun command
REPORT_WORDS = ("differs from its baseline; what changed: controller parameter position_weight 10.0 -> 3.0; ",
                "controller FMU's content changed (hover_lqr.fmu, sha256 ", "metrics out of tolerance",
                "case:     fsi, trajectory 1, controller hover_lqr, seed 1, stop time 3 s", " run ", " baseline ", "change ",
                "allowed +/-", "(rtol 1e-06, atol 1e-12)",
                "rerun:    tiltload run --scenario fsi --trajectory 1 --controller", "pytest --tiltload-update-baselines")

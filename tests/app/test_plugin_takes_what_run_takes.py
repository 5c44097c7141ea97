"""Issue 61: the pytest plugin's tiltload_run takes every object tiltload.run takes (a PythonController crashed it with
a TypeError, a Path divided by the object), and gives the run tiltload.run gives: a pytest session (the plugin's face)
and tiltload.run in this process (the API's) over the same case, metric for metric."""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import tiltload as tl

ROOT = Path(__file__).resolve().parents[2]
TRACED = ROOT / "docs" / "examples" / "hover_lqr_traced.py"  # a controller class written in plain numpy, traceable
RUN = {"scenario": "fsi", "trajectory": 0, "stop_time": 1.5, "no_gusts": True}

USER_TEST = f"""
import importlib.util, json, sys
from pathlib import Path
import tiltload as tl

spec = importlib.util.spec_from_file_location("user_traced", {str(TRACED)!r})
module = importlib.util.module_from_spec(spec)
sys.modules["user_traced"] = module
spec.loader.exec_module(module)
RUN = {RUN!r}


def _keep(name, result):
    Path(name).write_text(json.dumps({{"metrics": result.metrics, "ticks": result.ticks}}))


def test_a_python_controller(tiltload_run):
    _keep("python_controller.json", tiltload_run(controller=tl.PythonController(module.HoverLQRTraced), **RUN))


def test_a_case_and_options(tiltload_run):
    case = tl.Case(controller=tl.PythonController(module.HoverLQRTraced), **RUN)
    _keep("case.json", tiltload_run(case, tl.RunOptions(no_log=True)))
"""


@pytest.mark.slow
def test_the_plugin_runs_a_python_controller_as_tiltload_run_does(fmus, tmp_path):
    session = tmp_path / "session"
    session.mkdir()
    (session / "test_user.py").write_text(USER_TEST)
    done = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "--tiltload-fmus", str(fmus),
                           "test_user.py"], cwd=session, capture_output=True, text=True, timeout=1200,
                          env={**os.environ, "PYTHONDONTWRITEBYTECODE": "1"})
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
    spec = importlib.util.spec_from_file_location("user_traced", TRACED)  # imported as a user's script imports it
    module = importlib.util.module_from_spec(spec)
    sys.modules["user_traced"] = module
    spec.loader.exec_module(module)
    direct = tl.run(controller=tl.PythonController(module.HoverLQRTraced), fmus=fmus, no_log=True, **RUN)
    for name in ("python_controller.json", "case.json"):
        plugin = json.loads((session / name).read_text())
        assert plugin["metrics"] == pytest.approx(direct.metrics, rel=0, abs=0) and plugin["ticks"] == direct.ticks > 100

"""Issue 61: a falsification's replay names the controller FMU it searched by its SHA-256, not only by its path: the
replay (replay.sh, the command in the summary) refuses in one line, exit 2, a file rebuilt or replaced at that path,
and replays the one searched."""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest
import tiltload as tl

SPEC = """
name = "pinned"
optimizer = "uniform"
[base]
scenario = "fsi"
trajectory = 1
controller = "mine.fmu"
stop_time = 2.1
gusts = false
[[requirements]]
name = "swing"
formula = "always[1:2] (abs(plant.gamma_1) < 0.2)"
[[search]]
name = "amp"
target = "gust.amplitude"
range = [0.0, 20.0]
[gust]
start = 1.2
duration = 0.5
[budget]
simulations = 2
"""


def _replay(script: Path) -> subprocess.CompletedProcess:
    bin_dir = str(Path(sys.executable).parent)  # this environment's tiltload command
    return subprocess.run(["sh", str(script)], capture_output=True, text=True, timeout=900,
                          env={**os.environ, "PATH": bin_dir + os.pathsep + os.environ.get("PATH", "")})


@pytest.mark.slow
def test_a_replay_refuses_a_controller_rebuilt_at_the_searched_path(fmus, tmp_path):
    mine = tmp_path / "mine.fmu"
    shutil.copy(fmus / "TiltloadController.fmu", mine)  # the user's controller: a copy of ours
    searched = hashlib.sha256(mine.read_bytes()).hexdigest()
    (tmp_path / "f.toml").write_text(SPEC)
    found = tl.falsify(tmp_path / "f.toml", out=tmp_path / "out", fmus=fmus, workers=1, branch="off",
                       progress=lambda _: None)
    script = found.folder / "replay.sh"
    assert f"--expect-fmu controller={searched}" in script.read_text()
    assert f"--expect-fmu controller={searched}" in found.summary  # the command the summary and report show

    same = _replay(script)
    assert same.returncode in (0, 1), same.stderr[-2000:]  # the searched build: replayed (1: its requirement FAILs)

    with zipfile.ZipFile(mine, "a") as z:  # "rebuilt" at the same path: another file, still an FMU
        z.comment = b"rebuilt"
    assert hashlib.sha256(mine.read_bytes()).hexdigest() != searched
    other = _replay(script)
    lines = other.stderr.strip().splitlines()
    assert other.returncode == 2 and len(lines) == 1, other.stderr[-2000:]
    assert "--expect-fmu controller" in lines[0] and str(mine) in lines[0] and searched[:12] in lines[0]

"""The `tiltload` command as a user meets it: the main job and bad input."""

from __future__ import annotations

import subprocess
import sys


def run(*args, cwd):
    return subprocess.run([sys.executable, "-m", "tiltload.master.cli", *args], capture_output=True, text=True, cwd=cwd)


def test_run_builds_simulates_and_reports(plant_fmu, tmp_path):
    proc = run("run", "--fmus", str(plant_fmu.parent), "--out", str(tmp_path), cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    drift = float(proc.stdout.split("load drift ")[1].split()[0])
    assert drift < 1e-6
    assert (tmp_path / "plant_hover.png").stat().st_size > 10_000
    assert (tmp_path / "plant_hover.csv").read_text().count("\n") > 100


def test_bad_stop_time_is_one_line_and_nonzero(tmp_path):
    proc = run("run", "--stop-time", "-1", cwd=tmp_path)
    assert proc.returncode == 2 and "positive finite time" in proc.stderr
    assert "Traceback" not in proc.stderr


def test_unwritable_output_is_one_line_and_nonzero(plant_fmu, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    proc = run("run", "--fmus", str(plant_fmu.parent), "--out", str(blocker / "sub"), cwd=tmp_path)
    assert proc.returncode == 1 and proc.stderr.startswith("tiltload: error:")
    assert "Traceback" not in proc.stderr and len(proc.stderr.strip().splitlines()) == 1

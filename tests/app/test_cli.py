"""The `tiltload` command: a run's report, one-line errors for bad options, nothing left behind."""

from __future__ import annotations

import subprocess
import sys

import pytest
from tiltload.master.app.cli import main


def run(*args, cwd):
    return subprocess.run([sys.executable, "-m", "tiltload.master.app.cli", *args], capture_output=True, text=True, cwd=cwd)


def test_run_reports_metrics_log_and_plots(pipeline_fmus, tmp_path):
    fmus = next(iter(pipeline_fmus.values())).parent
    proc = run("run", "--stop-time", "2", "--fmus", str(fmus), "--out", str(tmp_path), "--quiet", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    ise = {line.split()[0]: float(line.split()[1]) for line in proc.stdout.splitlines() if line.strip().startswith(("ISE", "IADU"))}
    assert set(ise) == {"ISE(x)", "ISE(y)", "ISE(z)", "ISE(psi)", "IADU(f_R)", "IADU(f_L)", "IADU(tau_R)", "IADU(tau_L)"}
    assert all(v > 0 for v in ise.values())
    log = tmp_path / "zse_traj1_mixed_seed1.mcap"
    assert f"log: {log}" in proc.stdout
    pngs = sorted(p.name for p in tmp_path.glob("*.png"))
    assert len(pngs) == 7 and all((tmp_path / p).stat().st_size > 10_000 for p in pngs)
    again = run("plot", str(log), "--out", str(tmp_path / "again"), cwd=tmp_path)
    assert again.returncode == 0 and len(list((tmp_path / "again").glob("*.png"))) == 7


def test_bad_stop_time_is_one_line_and_nonzero(tmp_path):
    proc = run("run", "--stop-time", "-1", cwd=tmp_path)
    assert proc.returncode == 2 and "positive finite time" in proc.stderr
    assert "Traceback" not in proc.stderr


def test_unwritable_output_is_one_line_and_nonzero(pipeline_fmus, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    fmus = next(iter(pipeline_fmus.values())).parent
    proc = run("run", "--fmus", str(fmus), "--out", str(blocker / "sub"), "--quiet", cwd=tmp_path)
    assert proc.returncode == 1 and proc.stderr.startswith("tiltload: error:"), (proc.returncode, proc.stderr)
    assert "Traceback" not in proc.stderr and len(proc.stderr.strip().splitlines()) == 1, proc.stderr


def test_out_of_range_seed_and_a_path_as_name_are_refused(capsys):
    for args, needle in ((["--seed", "4294967297"], "must be a whole number from 0 to 2147483647"),
                         (["--seed", "-1"], "must be a whole number from 0 to 2147483647"),
                         (["--name", "../../x"], "must be a plain file name"),
                         (["--log-every", "0"], "must be a whole number >= 1")):
        with pytest.raises(SystemExit) as exit_:
            main(["run", *args])
        assert exit_.value.code == 2 and needle in capsys.readouterr().err


def test_a_run_leaves_no_temporary_folder(pipeline_fmus, tmp_path):
    import os

    temp = tmp_path / "tmp"
    temp.mkdir()
    fmus = next(iter(pipeline_fmus.values())).parent
    proc = subprocess.run([sys.executable, "-c", "from tiltload.master.app.cli import entry; entry()", "run", "--stop-time", "0.6",
                           "--fmus", str(fmus), "--out", str(tmp_path / "out"), "--quiet", "--no-plots"],
                          capture_output=True, text=True, env={**os.environ, "TMPDIR": str(temp)})
    assert proc.returncode == 0, proc.stderr
    assert list(temp.iterdir()) == []  # the four FMUs' extracted copies are gone

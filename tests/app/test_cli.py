"""The `tiltload` command: a run's report, one-line errors for bad options, nothing left behind."""

from __future__ import annotations

import subprocess
import sys

import pytest
from tiltload.master.app.cli import main


def run(*args, cwd):
    return subprocess.run([sys.executable, "-m", "tiltload.master.app.cli", *args], capture_output=True, text=True, cwd=cwd)


@pytest.mark.slow
def test_run_reports_metrics_log_and_plots(pipeline_fmus, tmp_path):
    fmus = next(iter(pipeline_fmus.values())).parent
    proc = run("run", "--stop-time", "2", "--fmus", str(fmus), "--out", str(tmp_path), "--quiet", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    ise = {line.split()[0]: float(line.split()[1]) for line in proc.stdout.splitlines() if line.strip().startswith(("ISE", "IADU"))}
    assert set(ise) == {"ISE(x)", "ISE(y)", "ISE(z)", "ISE(psi)", "IADU(f_R)", "IADU(f_L)", "IADU(tau_R)", "IADU(tau_L)"}
    assert all(v > 0 for v in ise.values())
    log = tmp_path / "zse_traj1_mixed_seed1_t2s.mcap"  # the default case, cut short: its name says so
    assert f"log: {log}" in proc.stdout
    pngs = sorted(p.name for p in tmp_path.glob("*.png"))
    assert len(pngs) == 7 and all((tmp_path / p).stat().st_size > 10_000 for p in pngs)
    again = run("plot", str(log), "--out", str(tmp_path / "again"), cwd=tmp_path)
    assert again.returncode == 0 and len(list((tmp_path / "again").glob("*.png"))) == 7


@pytest.mark.slow
def test_bad_stop_time_is_one_line_and_nonzero(tmp_path):
    proc = run("run", "--stop-time", "-1", cwd=tmp_path)
    assert proc.returncode == 2 and "must be a positive time in s, at most 1e+06, got -1" in proc.stderr
    assert "Traceback" not in proc.stderr


@pytest.mark.slow
def test_unwritable_output_is_one_line_and_nonzero(pipeline_fmus, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    fmus = next(iter(pipeline_fmus.values())).parent
    proc = run("run", "--fmus", str(fmus), "--out", str(blocker / "sub"), "--quiet", cwd=tmp_path)
    # refused by --out's type before the run (it was a run that failed at its first write: exit 1)
    assert proc.returncode == 2 and proc.stderr.startswith("tiltload run: error: argument --out:"), (proc.returncode, proc.stderr)
    assert "Traceback" not in proc.stderr and len(proc.stderr.strip().splitlines()) == 1, proc.stderr


def test_out_of_range_seed_and_a_path_as_name_are_refused(capsys):
    for args, needle in ((["--seed", "4294967297"], "must be a whole number from 0 to 2147483647"),
                         (["--seed", "-1"], "must be a whole number from 0 to 2147483647"),
                         (["--name", "../../x"], "must be a plain file name"),
                         (["--log-every", "0"], "must be a whole number >= 1")):
        with pytest.raises(SystemExit) as exit_:
            main(["run", *args])
        assert exit_.value.code == 2 and needle in capsys.readouterr().err


@pytest.mark.slow
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


def test_loop_options_with_a_system_file_are_refused_by_name(tmp_path, capsys):
    """A system file describes its own run: --controller and the like would be silently ignored, so they are refused."""
    system = tmp_path / "s.json"
    system.write_text("{}")
    code = main(["run", "--system", str(system), "--controller", "dlqr", "--set", "plant.m_L=0.2", "--seed", "3",
                 "--no-gusts", "--delay", "--scenario", "lkf", "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, err
    for flag in ("--scenario", "--controller", "--seed", "--delay", "--no-gusts"):
        assert flag in err[0]
    assert "--set" not in err[0]  # it sets the system's FMU values (issue 64), as in the loop
    assert main(["run", "--allow-external-fmus", "--quiet"]) == 2
    assert "--allow-external-fmus is for --system" in capsys.readouterr().err


def test_a_run_s_default_name_says_what_sets_it_apart():
    """Faults, --set, stop time, delay and calm air each give another log name; the default case keeps its own."""
    import argparse

    from tiltload.master.app import arguments
    from tiltload.master.app.case.options import resolve_loop

    def name(*argv):
        p = argparse.ArgumentParser()
        arguments.add_loop_options(p)
        return resolve_loop(p.parse_args(list(argv))).run_name(40.0)

    names = [name(), name("--faults", "docs/faults/gps_dropout.json"), name("--set", "plant.m_L=0.2"),
             name("--set", "plant.m_L=0.3"), name("--stop-time", "10"), name("--delay"), name("--no-gusts"),
             name("--set", "plant.m_L=0.2", "--set", "plant.l=0.7", "--set", "sensors.l=0.7", "--set", "sensors.seed=4")]
    assert names[0] == "zse_traj1_mixed_seed1" and name("--stop-time", "40") == names[0]
    assert len(set(names)) == len(names), names
    assert names[1] == "zse_traj1_mixed_seed1_faults-gps_dropout" and names[2] == "zse_traj1_mixed_seed1_set-plant.m_L=0.2"
    assert names[4].endswith("_t10s") and all("/" not in n for n in names)


@pytest.mark.slow
def test_a_log_of_the_same_name_is_not_replaced_without_a_word(pipeline_fmus, tmp_path):
    fmus = next(iter(pipeline_fmus.values())).parent
    args = ("run", "--scenario", "fsi", "--stop-time", "0.12", "--fmus", str(fmus), "--out", str(tmp_path), "--quiet",
            "--no-plots")
    first, second = run(*args, cwd=tmp_path), run(*args, cwd=tmp_path)
    assert first.returncode == second.returncode == 0, second.stderr
    assert "exists" not in first.stdout and f"note: {tmp_path / 'fsi_traj1_mixed_seed1_t0.12s.mcap'} exists" in second.stdout


def test_compare_tolerances_given_replace_the_baseline_s(tmp_path, capsys):
    """--rtol/--atol, as the help says, are the tolerances: a baseline's looser per-metric ones do not override them."""
    import json

    base = tmp_path / "base.json"
    base.write_text(json.dumps({"metrics": {"ISE(x)": 1.0, "ISE(y)": 2.0},
                                "tolerances": {"ISE(x)": {"rtol": 1e-4}, "rtol": 1e-4}}))
    run_file = tmp_path / "run.json"
    run_file.write_text(json.dumps({"metrics": {"ISE(x)": 1.0 + 1e-8, "ISE(y)": 2.0}}))
    assert main(["compare", str(run_file), str(base)]) == 0  # within the baseline's 1e-4
    assert main(["compare", str(run_file), str(base), "--rtol", "1e-12", "--atol", "0"]) == 1
    out = capsys.readouterr().out
    assert "DIFFERENT" in out and "ISE(x)" in out
    assert main(["compare", str(run_file), str(base), "--atol", "1e-7"]) == 0  # atol given, the baseline's rtol kept

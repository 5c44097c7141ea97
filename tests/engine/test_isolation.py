"""FMUs in worker processes of their own: a crash, exit() or hang ends the run with one line; results as in process."""

from __future__ import annotations

import os
import signal
import subprocess
import zipfile
from pathlib import Path

import pytest
from support.fmi2_session import foreign_copy, wrap_misbehaving
from tiltload.master.app.cli import main
from tiltload.master.app.loop.fmus import is_foreign
from tiltload.master.app.loop.thesis import default_system, loop_metrics
from tiltload.master.engine.execution import Execution
from tiltload.master.engine.isolation.process import IsolatedFmu
from tiltload.master.engine.log import reader as log_reader

MISBEHAVIOURS = {
    "segfault": ("os.kill(os.getpid(), signal.SIGSEGV)", "crashed (SIGSEGV) in doStep at t=0.504 s"),
    "abort": ("os.abort()", "crashed (SIGABRT) in doStep at t=0.504 s"),
    "exit": ("os._exit(3)", "ended its process with exit(3) in doStep at t=0.504 s"),
    "hang": ("time.sleep(3600)", "doStep at t=0.504 s did not return within 1 s (watchdog"),
    "nan": ("return float('nan'), 0.0, 0.0, 0.0", "doStep at t=0.504 s failed (discard)"),
}


@pytest.fixture(scope="module")
def misbehaving(tmp_path_factory):
    """One `tiltload wrap` controller per misbehaviour, which strikes at t = 0.5 s."""
    return wrap_misbehaving(tmp_path_factory.mktemp("misbehaving"), {m: act for m, (act, _) in MISBEHAVIOURS.items()}, 0.5)


def workers(parent: int | None = None) -> list[str]:
    """The FMU workers whose parent is this process (or `parent`): other tiltload runs on the machine do not count."""
    parent = os.getpid() if parent is None else parent
    ps = subprocess.run(["ps", "-ww", "-eo", "pid,ppid,args"], capture_output=True, text=True).stdout  # -ww: never cut
    return [line for line in ps.splitlines()[1:]
            if "tiltload.master.command_line.worker" in line and int(line.split()[1]) == parent]


@pytest.mark.parametrize("mode", list(MISBEHAVIOURS))
def test_a_misbehaving_controller_ends_the_run_with_one_line_and_its_log(mode, misbehaving, fmus, tmp_path, capsys):
    code = main(["run", "--controller", str(misbehaving[mode]), "--scenario", "fsi", "--stop-time", "2", "--step-timeout", "1",
                 "--fmus", str(fmus), "--out", str(tmp_path), "--quiet", "--no-plots"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1
    assert len(err) == 1 and err[0].startswith("tiltload: error: controller: ") and MISBEHAVIOURS[mode][1] in err[0], err
    assert "Traceback" not in err[0] and "the log is readable up to t = 0.504 s" in err[0]
    plant = log_reader.read(next(tmp_path.glob("*.mcap")), topics=["/plant"])["/plant"]
    assert plant[-1]["t"] == pytest.approx(0.504)  # everything up to the failing step is on disk
    assert not workers()


def test_an_isolated_fmu_gives_the_in_process_results_bit_for_bit(fmus, tmp_path):
    """Our controller, stripped of its build record, is foreign: hosted in a worker, it must compute the same loop."""
    foreign = foreign_copy(fmus / "TiltloadController.fmu", tmp_path / "Foreign.fmu")
    results = {}
    for trust in (True, False):
        system = default_system(fmus, "lkf", 1, "mixed")
        system.instances[2].fmu = foreign
        ex = Execution(system, [loop_metrics()], isolate=None if trust else is_foreign)
        ex.instantiate()
        assert isinstance(ex.instances["controller"], IsolatedFmu) is not trust
        ex.run(1.2)
        results[trust] = ex.observers[0].table(), ex.instances["plant"].values["Real"].copy()
        ex.restart()  # fmi2Reset and initialization through the worker too
        ex.run(0.6)
        ex.close()
    assert results[True][0] == results[False][0]
    assert (results[True][1] == results[False][1]).all()
    assert not workers()


def test_a_foreign_fmu_without_its_resources_is_one_line(misbehaving, fmus, tmp_path, capsys):
    """A pythonfmu controller without resources/ crashed the master (exit -11) when it ran in process."""
    broken = foreign_copy(misbehaving["nan"], tmp_path / "NoResources.fmu", drop=("resources/",))
    code = main(["run", "--controller", str(broken), "--stop-time", "1", "--fmus", str(fmus), "--out", str(tmp_path),
                 "--quiet", "--no-plots"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1 and len(err) == 1 and err[0].startswith("tiltload: error: controller: "), err
    assert not workers()


@pytest.mark.slow
def test_a_killed_master_leaves_no_worker_behind(misbehaving, fmus, tmp_path):
    """SIGKILL gives the master no chance to clean up: the worker must die with it (even while hung)."""
    import sys
    import time

    proc = subprocess.Popen([sys.executable, "-m", "tiltload.master.app.cli", "run", "--controller", str(misbehaving["hang"]),
                             "--stop-time", "2", "--fmus", str(fmus), "--out", str(tmp_path), "--quiet", "--no-plots"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 60
    while not workers(proc.pid) and time.time() < deadline:
        time.sleep(0.1)
    hung = workers(proc.pid)
    assert hung, f"the worker never started: {proc.poll()}, {proc.stderr.read() if proc.poll() is not None else ''}"
    time.sleep(1.0)  # now hung in doStep
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    pid = int(hung[0].split()[0])
    deadline = time.time() + 10
    while Path(f"/proc/{pid}").exists() and time.time() < deadline:
        time.sleep(0.1)
    assert not Path(f"/proc/{pid}").exists()  # orphaned, it would live on (hung) under init


def _empty_soon(folder: Path, seconds: float = 10.0) -> list[str]:
    """What is left in folder once the reapers of dead processes had their moment."""
    import time

    deadline = time.time() + seconds
    while list(folder.iterdir()) and time.time() < deadline:
        time.sleep(0.1)
    return sorted(p.name for p in folder.iterdir())


def _guid_mismatch(fmu: Path, dest: Path) -> Path:
    """The FMU with one digit of its model description's GUID changed: its binary refuses to instantiate."""
    import re

    with zipfile.ZipFile(fmu) as src, zipfile.ZipFile(dest, "w") as out:
        for item in src.infolist():
            data = src.read(item.filename)
            if item.filename == "modelDescription.xml":
                data = re.sub(rb'guid="\{(.)', lambda m: b'guid="{' + (b"0" if m.group(1) != b"0" else b"1"), data, count=1)
            out.writestr(item, data)
    return dest


@pytest.mark.parametrize("how", ["segfault", "guid mismatch", "guid mismatch, trusted", "SIGKILL"])
@pytest.mark.slow
def test_a_failed_run_leaves_no_temporary_folder(how, misbehaving, fmus, tmp_path):
    """Every unpacked FMU copy goes, also when its process cannot clean up: a worker that segfaults, a master killed."""
    import sys

    temp = tmp_path / "tmp"
    temp.mkdir()
    controller = (misbehaving["segfault"] if how == "segfault" else misbehaving["hang"] if how == "SIGKILL"
                  else _guid_mismatch(fmus / "TiltloadController.fmu", tmp_path / "BadGuid.fmu"))
    argv = [sys.executable, "-c", "from tiltload.master.app.cli import entry; entry()", "run", "--controller", str(controller),
            "--scenario", "fsi", "--stop-time", "1", "--fmus", str(fmus), "--out", str(tmp_path / "out"), "--quiet",
            "--no-plots", *(["--trust-fmus"] if "trusted" in how else [])]
    env = {**os.environ, "TMPDIR": str(temp)}
    if how == "SIGKILL":
        import time

        proc = subprocess.Popen(argv, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        deadline = time.time() + 60
        while not workers(proc.pid) and time.time() < deadline:
            time.sleep(0.1)
        time.sleep(1.0)  # the hung worker holds a temporary copy (the loop's own FMUs: the machine's cache, fmu_cache.py)
        assert len(list(temp.iterdir())) >= 1
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    else:
        proc = subprocess.run(argv, env=env, capture_output=True, text=True)
        assert proc.returncode == 1 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert _empty_soon(temp) == []


def test_a_worker_starts_numeric_thread_pools_with_one_thread_unless_the_user_set_them(fmus, tmp_path, monkeypatch):
    """It steps one FMU in lock-step with the master: OpenBLAS, OpenMP and MKL get one thread there, as the worker
    process itself sees its environment; a user's own setting is kept."""
    import sys

    from tiltload.master.engine.isolation import process

    seen = tmp_path / "environment.txt"
    script = tmp_path / "worker.py"
    script.write_text(f"import os, runpy\nopen({str(seen)!r}, 'w').write(' '.join(os.environ.get(n, '-') for n in "
                      f"{process.SINGLE_THREADED!r}))\nrunpy.run_module({process.WORKER_MODULE!r}, run_name='__main__')\n")
    monkeypatch.setattr(process, "WORKER_COMMAND", (sys.executable, str(script)))
    monkeypatch.setenv("OMP_NUM_THREADS", "3")
    monkeypatch.delenv("OPENBLAS_NUM_THREADS", raising=False)
    monkeypatch.delenv("MKL_NUM_THREADS", raising=False)
    system = default_system(fmus, "fsi", 1, "mixed", 1)
    system.instance("controller").fmu = foreign_copy(fmus / "TiltloadController.fmu", tmp_path / "Foreign.fmu")
    ex = Execution(system, [loop_metrics()], isolate=is_foreign)
    try:
        ex.instantiate()
        ex.run(0.1)
    finally:
        ex.close()
    assert seen.read_text() == "1 3 1"  # OPENBLAS_NUM_THREADS, OMP_NUM_THREADS (the user's), MKL_NUM_THREADS

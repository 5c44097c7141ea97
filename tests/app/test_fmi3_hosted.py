"""FMI 3.0 FMUs, plain and with clocks, hosted outside the master: in a worker process of their own and on
`tiltload serve`. The same logs as in process to the bit (restart and snapshots included), and a foreign FMI 3.0
controller that crashes, exits or hangs in its own process ends the run with one line and a readable log."""

from __future__ import annotations

import re

import pytest
from support.fmi2_session import foreign_copy
from support.fmi3_misbehaving import misbehaving_fmi3
from support.remote import ServerProcess, token_file
from tiltload.master.app.cli import main
from tiltload.master.app.loop.fmus import fmu_folder, is_foreign
from tiltload.master.app.loop.thesis import default_system, loop_metrics
from tiltload.master.engine.execution import Execution
from tiltload.master.engine.fmi.fmi3 import Fmu3Slave
from tiltload.master.engine.isolation.process import IsolatedFmu
from tiltload.master.engine.log import reader as log_reader

CLOCKS = {"clocked": ["--clocks"], "plain": []}
TOPICS = ["/scenario", "/sensors", "/controller", "/plant"]


@pytest.fixture(scope="module")
def fmi3_folder(fmus):
    """The FMI 3.0 loop's FMUs, plain and with clocks, for this machine (fmus/fmi3/)."""
    from tiltload.master.app.loop.fmus import build_all

    for clocked in (False, True):
        build_all(fmu_folder(fmus, 3), progress=lambda *_: None, fmi_version=3, clocked=clocked)
    return fmu_folder(fmus, 3)


@pytest.fixture(scope="module")
def token(tmp_path_factory):
    return token_file(tmp_path_factory.mktemp("secret"))


def run(fmus, out, name, *extra) -> int:
    """`tiltload run` of the FMI 3.0 loop, logged as out/name.mcap."""
    return main(["run", "--scenario", "fsi", "--fmi", "3", "--fmus", str(fmus), "--out", str(out), "--no-plots", "--quiet",
                 "--name", name, *extra])


def metric_rows(text: str) -> list[str]:
    return [ln for ln in text.splitlines() if re.match(r"^\s+(ISE|IADU)\(", ln)]


@pytest.mark.parametrize("kind", list(CLOCKS))
@pytest.mark.slow
def test_an_fmi3_controller_on_tiltload_serve_gives_the_in_process_run_bit_for_bit(kind, fmus, fmi3_folder, token, tmp_path, capsys):
    """`tiltload run --fmi 3 [--clocks] --remote controller=127.0.0.1:PORT`: a tick's Event Mode, clock activation,
    discrete-state update and staging happen in the server's worker, one round trip; the logs and metrics equal."""
    assert run(fmus, tmp_path, "local", "--stop-time", "3", *CLOCKS[kind]) == 0  # builds the FMI 3.0 FMUs if needed
    local = metric_rows(capsys.readouterr().out)
    srv = ServerProcess(fmi3_folder, token)
    try:
        assert run(fmus, tmp_path, "remote", "--stop-time", "3", *CLOCKS[kind], "--remote", f"controller={srv.address}",
                   "--token-file", str(token)) == 0
        remote = metric_rows(capsys.readouterr().out)
        srv.wait_for("session ended (controller: exit 0)")
    finally:
        srv.stop()
    served = "TiltloadControllerClocked.fmu" if kind == "clocked" else "TiltloadController.fmu"
    assert any(f"serving {served} as controller" in line for line in srv.lines), srv.lines
    assert len(local) == 8 and remote == local
    a = log_reader.read(tmp_path / "local.mcap", topics=TOPICS)
    b = log_reader.read(tmp_path / "remote.mcap", topics=TOPICS)
    for topic in TOPICS:
        assert len(a[topic]) > 200 and a[topic] == b[topic], topic


@pytest.mark.slow
def test_a_snapshot_of_a_remote_clocked_fmi3_controller_continues_on_the_server(fmus, fmi3_folder, token, tmp_path, capsys):
    """The clocked controller's state (the FMU's own, its held clocked outputs, a pending event) travels both ways:
    the continued remote run is the tail of the uninterrupted in-process run, to the bit."""
    srv = ServerProcess(fmi3_folder, token)
    remote = ["--remote", f"controller={srv.address}", "--token-file", str(token)]
    snap = tmp_path / "remote.snapshot"
    try:
        assert run(fmus, tmp_path, "local", "--stop-time", "3", "--clocks") == 0
        assert run(fmus, tmp_path, "taken", "--stop-time", "3", "--clocks", "--snapshot-at", "1.5", str(snap), *remote) == 0
        assert main(["run", "--fmus", str(fmus), "--out", str(tmp_path), "--quiet", "--no-plots", "--from-snapshot", str(snap),
                     "--name", "rest", *remote]) == 0
        assert "continuing from" in capsys.readouterr().out
        srv.wait_for("session ended (controller: exit 0)")
    finally:
        srv.stop()
    whole = log_reader.read(tmp_path / "local.mcap", topics=TOPICS)
    rest = log_reader.read(tmp_path / "rest.mcap", topics=TOPICS)
    for topic in TOPICS:
        assert len(rest[topic]) > 100 and rest[topic] == whole[topic][-len(rest[topic]):], topic


@pytest.mark.parametrize("kind", list(CLOCKS))
def test_a_foreign_fmi3_controller_in_its_own_process_gives_the_in_process_results_bit_for_bit(kind, fmi3_folder, tmp_path):
    """Our FMI 3.0 controller without its build record is foreign: hosted in a worker, through a restart
    (fmi3Reset and the initialization) and a state saved and restored over the pipe, the loop is the same."""
    clocked, folder = kind == "clocked", fmi3_folder
    stem = "TiltloadControllerClocked" if clocked else "TiltloadController"
    foreign = foreign_copy(folder / f"{stem}.fmu", tmp_path / f"Foreign{stem}.fmu")
    results = {}
    for trust in (True, False):
        system = default_system(folder, "lkf", 1, "mixed", fmi=3, clocked=clocked)
        system.instance("controller").fmu = foreign
        ex = Execution(system, [loop_metrics()], isolate=None if trust else is_foreign)
        ex.instantiate()
        try:
            hosted = ex.instances["controller"]
            assert isinstance(hosted, Fmu3Slave if trust else IsolatedFmu)
            ex.run(0.6)
            state = hosted.get_state()
            ex.run(1.2)
            first = ex.observers[0].table(), ex.instances["controller"].values["Real"].copy()
            hosted.set_state(state)  # back to t = 0.6 s: the controller's outputs are those it had then
            at_06 = hosted.values["Real"].copy()
            ex.restart()
            ex.run(0.6)
            results[trust] = first, at_06, ex.observers[0].table(), hosted.values["Real"].copy()
        finally:
            ex.close()
    (m1, v1), s1, r1, w1 = results[True]
    (m2, v2), s2, r2, w2 = results[False]
    assert m1 == m2 and r1 == r2 and (v1 == v2).all() and (s1 == s2).all() and (w1 == w2).all()
    assert (s1 == w1).all()  # the state restored at 0.6 s gives the outputs a fresh run has at 0.6 s


MISBEHAVIOURS = {
    "segfault": "crashed (SIGSEGV) in doStep at t=0.504 s",
    "exit": "ended its process with exit(3) in doStep at t=0.504 s",
    "hang": "doStep at t=0.504 s did not return within 1 s (watchdog",
}


@pytest.fixture(scope="module")
def misbehaving3(fmi3_folder, tmp_path_factory):
    """Our clocked FMI 3.0 controller, foreign, misbehaving in C from t = 0.5 s (support/fmi3_misbehaving.py)."""
    controller = fmi3_folder / "TiltloadControllerClocked.fmu"
    return misbehaving_fmi3(controller, tmp_path_factory.mktemp("misbehaving3"), MISBEHAVIOURS, 0.5)


@pytest.mark.parametrize("mode", list(MISBEHAVIOURS))
@pytest.mark.slow
def test_a_misbehaving_fmi3_controller_ends_the_run_with_one_line_and_its_log(mode, misbehaving3, fmus, tmp_path, capsys):
    code = run(fmus, tmp_path, mode, "--clocks", "--controller", str(misbehaving3[mode]), "--stop-time", "2",
               "--step-timeout", "1")
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1
    assert len(err) == 1 and err[0].startswith("tiltload: error: controller: ") and MISBEHAVIOURS[mode] in err[0], err
    assert "Traceback" not in err[0] and "the log is readable up to t = 0.504 s" in err[0]
    plant = log_reader.read(tmp_path / f"{mode}.mcap", topics=["/plant"])["/plant"]
    assert plant[-1]["t"] == pytest.approx(0.504)

"""`tiltload run --remote` and `tiltload serve` on the command line: a killed server is one line and a readable log,
a restarted one serves the next run; bad options and files are one line; remote in JSON and SSP descriptions."""

from __future__ import annotations

import json
import re
import threading
import time
from pathlib import Path

import pytest
from support.remote import ServerProcess, token_file
from tiltload.controller_fmu.design.cache import cache_root
from tiltload.master.app.cli import main
from tiltload.master.engine import system as sysdesc
from tiltload.master.engine.log import reader as log_reader
from tiltload.master.engine.ssp.load import load


@pytest.fixture(scope="module")
def token(tmp_path_factory):
    return token_file(tmp_path_factory.mktemp("secret"))


def alive(pid: int, wait: float = 5.0) -> bool:
    """Is the process still running (a zombie, dead and waiting for its new parent to reap it, is not) after wait s?"""
    deadline = time.monotonic() + wait
    while time.monotonic() < deadline:
        try:
            state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except OSError:
            return False
        if state == "Z":
            return False
        time.sleep(0.05)
    return True


def exit_code(argv: list[str]) -> int:
    """main's return, or the code a usage error exits with."""
    try:
        return main(argv)
    except SystemExit as done:
        return done.code


def run(fmus, out, *extra):
    return exit_code(["run", "--scenario", "fsi", "--fmus", str(fmus), "--out", str(out), "--quiet", "--no-plots", *extra])


@pytest.mark.slow
def test_killing_the_server_mid_run_is_one_line_the_log_is_kept_and_a_restarted_server_serves(fmus, token, tmp_path, capsys):
    srv = ServerProcess(fmus, token)
    port = srv.address.rsplit(":", 1)[1]

    log = tmp_path / "killed.mcap"
    workers = []

    def kill_once_stepping():
        srv.wait_for("serving TiltloadController.fmu as controller")
        deadline = time.monotonic() + 120
        growing = [log, log.with_name(log.name + ".partial")]  # the logger may write under a temporary name
        while time.monotonic() < deadline and not any(f.is_file() and f.stat().st_size > 100_000 for f in growing):
            time.sleep(0.05)  # well into the run: a few dozen ticks on disk
        workers.extend(srv.workers())
        srv.kill()
    killer = threading.Thread(target=kill_once_stepping)
    killer.start()
    code = run(fmus, tmp_path, "--remote", f"controller={srv.address}", "--token-file", str(token), "--stop-time", "300",
               "--name", "killed")
    killer.join()
    captured = capsys.readouterr()
    err = captured.err.strip().splitlines()
    assert code == 1 and len(err) == 1, err
    assert re.match(rf"tiltload: error: controller: the connection to tiltload serve at 127\.0\.0\.1:{port} was lost in "
                    r"doStep at t=[0-9.]+ s \(the server, its FMU's process or the network went away\); "
                    r"the log is readable up to t = [0-9.]+ s$", err[0]), err[0]
    failed_at = float(re.search(r"doStep at t=([0-9.]+) s", err[0]).group(1))
    readable = float(re.search(r"readable up to t = ([0-9.]+) s", err[0]).group(1))
    assert 0.1 < failed_at < 290 and readable == pytest.approx(failed_at, abs=1e-3)
    plant = log_reader.read(log, topics=["/plant"])["/plant"]
    assert plant[-1]["t"] == pytest.approx(failed_at, abs=1e-9)  # every tick up to the failing step is on disk
    assert "remote: controller on tiltload serve at" in captured.out
    assert len(workers) == 1 and not alive(workers[0])  # the FMU's process died with the server

    again = ServerProcess(fmus, token, bind=f"127.0.0.1:{port}")  # the same port, at once
    try:
        assert run(fmus, tmp_path, "--remote", f"controller={again.address}", "--token-file", str(token), "--stop-time", "0.6",
                   "--name", "again") == 0
        assert log_reader.read(tmp_path / "again.mcap", topics=["/plant"])["/plant"][-1]["t"] == pytest.approx(0.6)
        again.wait_for("session ended (controller: exit 0)")
    finally:
        again.stop()


def test_a_server_that_is_not_running_is_one_line(fmus, token, tmp_path, capsys):
    code = run(fmus, tmp_path, "--remote", "controller=127.0.0.1:1", "--token-file", str(token), "--stop-time", "0.12")
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1 and len(err) == 1
    assert "controller: tiltload serve at 127.0.0.1:1: cannot connect (Connection refused)" in err[0]


@pytest.mark.parametrize("extra, needle", [
    (["--remote", "controller=127.0.0.1:7390"], "controller run on tiltload serve: give its shared secret with --token-file"),
    (["--remote", "controller=nowhere"], "argument --remote: 'nowhere' is not HOST:PORT"),
    (["--remote", "controller"], "argument --remote: must be INSTANCE=HOST:PORT"),
    (["--remote", "ctrl=127.0.0.1:7390", "--token-file", "TOKEN"], "unknown FMU instance 'ctrl'"),
    (["--remote", "controller=127.0.0.1:7390", "--token-file", "LOOSE"], "can be read by other users (chmod 600"),
    (["--remote", "controller=127.0.0.1:7390", "--token-file", "/no/such/token"], "token file /no/such/token: No such file"),
])
def test_bad_remote_options_are_one_line_and_exit_2(extra, needle, fmus, token, tmp_path, capsys):
    loose = token_file(tmp_path, "loose")
    loose.chmod(0o640)
    extra = [{"TOKEN": str(token), "LOOSE": str(loose)}.get(x, x) for x in extra]
    assert run(fmus, tmp_path, "--stop-time", "0.12", *extra) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and needle in err[0], err


@pytest.mark.parametrize("extra, needle", [
    (["--fmus", "/no/such/folder"], "argument --fmus: /no/such/folder: no such folder"),
    (["--token-file", "LOOSE"], "can be read by other users"),
    (["--bind", "localhost"], "argument --bind: 'localhost' is not HOST:PORT"),
    (["--bind", "203.0.113.9:7390"], "cannot listen on 203.0.113.9:7390"),  # not an address of this machine
])
def test_bad_serve_options_are_one_line_and_exit_2(extra, needle, fmus, token, tmp_path, capsys):
    loose = token_file(tmp_path, "loose")
    loose.chmod(0o604)
    args = {"--fmus": str(fmus), "--token-file": str(token)}
    for i in range(0, len(extra), 2):
        args[extra[i]] = {"LOOSE": str(loose)}.get(extra[i + 1], extra[i + 1])
    assert exit_code(["serve", *[x for kv in args.items() for x in kv]]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and needle in err[0], err


def test_a_port_in_use_is_one_line(fmus, token, capsys):
    srv = ServerProcess(fmus, token)
    try:
        assert main(["serve", "--fmus", str(fmus), "--token-file", str(token), "--bind", srv.address]) == 2
        assert f"cannot listen on {srv.address}: Address already in use" in capsys.readouterr().err
    finally:
        srv.stop()


@pytest.mark.slow
def test_remote_in_a_json_description_and_an_ssp_package(fmus, token, tmp_path, capsys):
    srv = ServerProcess(fmus, token)
    try:
        description = tmp_path / "loop.json"
        description.write_text(json.dumps({"tick": 0.012, "instances": [
            {"name": "scenario", "fmu": str(fmus / "TiltloadScenario.fmu"), "parameters": {"trajectory": 1}},
            {"name": "sensors", "fmu": str(fmus / "TiltloadSensors.fmu")},
            {"name": "controller", "fmu": str(fmus / "TiltloadController.fmu"), "remote": srv.address,
             "parameters": {"estimator": "none"}},
            {"name": "plant", "fmu": str(fmus / "TiltloadPlant.fmu"), "timing": "continuous"}]}))
        assert sysdesc.load(description).instance("controller").remote == srv.address
        assert main(["run", "--system", str(description), "--token-file", str(token), "--stop-time", "0.24",
                     "--out", str(tmp_path), "--quiet", "--no-plots"]) == 0
        assert "remote: controller on tiltload serve at" in capsys.readouterr().out
        srv.wait_for("session ended (controller: exit 0)")

        package = tmp_path / "loop.ssp"
        assert main(["ssp", "export", str(package), "--fmus", str(fmus), "--scenario", "fsi", "--stop-time", "0.24",
                     "--schedule", "ordered", "--remote", f"controller={srv.address}"]) == 0
        system, _, _ = load(package, cache_root() / "ssp")
        assert system.instance("controller").remote == srv.address and system.instance("plant").remote is None
        assert main(["run", "--system", str(package), "--token-file", str(token), "--out", str(tmp_path), "--quiet",
                     "--no-plots"]) == 0
        srv.wait_for("session ended (controller: exit 0)")
    finally:
        srv.stop()
    bad = json.loads(description.read_text())
    bad["instances"][2]["remote"] = "somewhere"
    description.write_text(json.dumps(bad))
    assert main(["run", "--system", str(description), "--token-file", str(token), "--quiet"]) == 2
    assert "controller: remote 'somewhere' is not HOST:PORT" in capsys.readouterr().err


@pytest.mark.slow
def test_a_snapshot_of_a_remote_controller_continues_on_the_server_and_nowhere_else(fmus, token, tmp_path, capsys):
    """The controller's state travels over the link both ways (get_state, set_state): the continued run's log is the
    tail of the uninterrupted in-process run's, to the bit. Where each instance runs may not change across it."""
    srv = ServerProcess(fmus, token)
    remote = ["--remote", f"controller={srv.address}", "--token-file", str(token)]
    snap, local_snap = tmp_path / "remote.snapshot", tmp_path / "local.snapshot"
    try:
        assert run(fmus, tmp_path, "--stop-time", "4", "--snapshot-at", "2", str(local_snap), "--name", "local") == 0
        assert run(fmus, tmp_path, "--stop-time", "4", "--snapshot-at", "2", str(snap), "--name", "taken", *remote) == 0
        assert "snapshot at t = 2.004 s" in capsys.readouterr().out
        continued = ["run", "--fmus", str(fmus), "--out", str(tmp_path), "--quiet", "--no-plots", "--from-snapshot"]
        assert main([*continued, str(snap), "--name", "rest", *remote]) == 0
        assert "continuing from" in capsys.readouterr().out
        srv.wait_for("session ended (controller: exit 0)")
        whole = log_reader.read(tmp_path / "local.mcap", topics=["/plant", "/controller"])
        rest = log_reader.read(tmp_path / "rest.mcap", topics=["/plant", "/controller"])
        for topic in ("/plant", "/controller"):
            assert len(rest[topic]) > 100 and rest[topic] == whole[topic][-len(rest[topic]):], topic
        for path, extra, needle in ((snap, [], "controller ran on tiltload serve at 127.0.0.1:"),
                                    (local_snap, remote, "controller ran in this master's machine")):
            assert main([*continued, str(path), *extra]) == 2
            err = capsys.readouterr().err.strip().splitlines()
            assert len(err) == 1 and needle in err[0], err
    finally:
        srv.stop()

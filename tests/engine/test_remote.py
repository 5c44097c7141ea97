"""FMUs on `tiltload serve`: the same results as in process; every client that is not a master with the secret
is refused with a log line, and the server goes on serving; the watchdog and the one-line errors over TCP."""

from __future__ import annotations

import os
import socket
import struct
import time
import zipfile

import pytest
from support.fmi2_session import wrap_misbehaving
from support.remote import Namespace, ServerProcess, board_copy, connect, netns_available, token_file
from tiltload.master.app.loop.thesis import default_system, loop_metrics
from tiltload.master.engine.errors import DescriptionError, ExecutionError
from tiltload.master.engine.execution import Execution
from tiltload.master.engine.fmi.binaries import library_member
from tiltload.master.engine.fmi.model_description import read_fmu
from tiltload.master.engine.isolation import handshake, wire
from tiltload.master.engine.isolation.elf import library_machine, this_machine
from tiltload.master.engine.isolation.hosting import remote_fmu
from tiltload.master.engine.isolation.process import IsolatedFmu
from tiltload.master.engine.isolation.remote_client import RemoteHost
from tiltload.master.engine.isolation.transport import Channel, FrameTooLarge, LinkClosed

GIGABYTE = 1 << 30


@pytest.fixture(scope="module")
def token(tmp_path_factory):
    return token_file(tmp_path_factory.mktemp("secret"))


@pytest.fixture(scope="module")
def server(fmus, token):
    """One server for the module, on loopback, in a process tree of its own; clients have 1 s to name their FMU."""
    srv = ServerProcess(fmus, token, "--handshake-timeout", "1", "--idle-timeout", "20")
    yield srv
    srv.stop()


def loop(fmus, address=None, token=None):
    system = default_system(fmus, "lkf", 1, "mixed")
    ctrl = system.instance("controller")
    ctrl.remote, ctrl.token_file = address, token
    return system


def run_loop(system, stop: float, restart: float | None = None):
    ex = Execution(system, [loop_metrics()])
    ex.instantiate()
    try:
        hosted = ex.instances["controller"]
        ex.run(stop)
        out = ex.observers[0].table(), ex.instances["plant"].values["Real"].copy()
        if restart is not None:
            ex.restart()  # fmi2Reset and the initialization across the network too
            ex.run(restart)
            out += (ex.observers[0].table(),)
        return hosted, out
    finally:
        ex.close()


def served_fine(server, fmus, token) -> None:
    """The next master gets its FMU and steps it."""
    hosted, (metrics, _) = run_loop(loop(fmus, server.address, token), 0.12)
    assert isinstance(hosted.host, RemoteHost) and metrics["ISE(x)"] > 0
    server.wait_for("session ended (controller: exit 0)")


@pytest.mark.slow
def test_a_remote_controller_gives_the_in_process_results_bit_for_bit(fmus, token, server):
    _, local = run_loop(loop(fmus), 1.2, restart=0.6)
    hosted, remote = run_loop(loop(fmus, server.address, token), 1.2, restart=0.6)
    assert isinstance(hosted, IsolatedFmu) and isinstance(hosted.host, RemoteHost)
    assert local[0] == remote[0] and local[2] == remote[2]
    assert (local[1] == remote[1]).all()
    line = server.wait_for("session ended")
    assert "exit 0" in line and not server.workers()


@pytest.mark.skipif(not netns_available(), reason="needs root and iproute2 for a network namespace")
def test_a_server_in_its_own_network_namespace_gives_the_same_results(fmus, token):
    """As on a board: another network stack, reached through a veth pair, the server started without the application."""
    space = Namespace()
    try:
        srv = ServerProcess(fmus, token, bind=f"{space.server_ip}:0", netns=space.name, engine_only=True)
        try:
            assert srv.address.startswith(space.server_ip)
            _, local = run_loop(loop(fmus), 0.6)
            _, remote = run_loop(loop(fmus, srv.address, token), 0.6)
            assert local[0] == remote[0] and (local[1] == remote[1]).all()
            assert f"{space.master_ip}:" in srv.wait_for("authenticated")  # it came over the veth pair
        finally:
            srv.stop()
    finally:
        space.remove()


def peer_lines(server, sock: socket.socket) -> list[str]:
    """The server's log lines about the connection of sock."""
    host, port = sock.getsockname()[:2]
    return [line for line in server.lines if f" {host}:{port}:" in line]


def refused(server, sock: socket.socket, why: str) -> list[str]:
    host, port = sock.getsockname()[:2]
    line = server.wait_for(f"{host}:{port}: refused")
    assert why in line, line
    return peer_lines(server, sock)


def authenticated(address: str, token) -> socket.socket:
    sock = connect(address)
    handshake.client_side(sock, handshake.read_token(token), 5)
    return sock


def open_request(md, instance="controller", protocol=handshake.PROTOCOL) -> bytes:
    return wire.control({"op": "open", "protocol": protocol, "model_identifier": md.coSimulation.modelIdentifier, "guid": md.guid,
                         "instance": instance, "byteorder": "little", "client": "a test"})


def closed_by_server(sock: socket.socket, timeout: float = 5.0) -> bool:
    sock.settimeout(timeout)
    try:
        while sock.recv(4096):
            pass
    except ConnectionResetError:
        pass
    return True


def test_a_wrong_token_is_refused_and_the_server_serves_the_next_master(fmus, token, server, tmp_path):
    wrong = token_file(tmp_path, "wrong")
    md = read_fmu(fmus / "TiltloadController.fmu", "controller")
    with pytest.raises(ExecutionError, match=r"controller: tiltload serve at .*: it refused the token \(the --token-file"):
        RemoteHost(server.address, handshake.read_token(wrong), "controller", md)
    server.wait_for("refused: wrong token")
    assert not server.workers()
    served_fine(server, fmus, token)


@pytest.mark.parametrize("sends, why", [
    (None, "no greeting within the time allowed"),  # connects and waits
    (b"\x00" * 7 + os.urandom(200), "not a tiltload client"),  # garbage
    (struct.pack("<I", GIGABYTE) + b"S" * 64, "not a tiltload client"),  # a frame of 1 GB announced, no handshake
    ("open", "not a tiltload client"),  # no token: straight to the request for an FMU
], ids=["waits", "garbage", "1GB-frame", "no-token"])
def test_a_client_without_the_secret_is_dropped_and_nothing_is_loaded(sends, why, fmus, token, server):
    sock = connect(server.address)
    if sends == "open":
        sends = transport_frame(open_request(read_fmu(fmus / "TiltloadController.fmu", "controller")))
    if sends is not None:
        sock.sendall(sends)
    lines = refused(server, sock, why)
    assert closed_by_server(sock)
    sock.close()
    assert not any("serving" in line or "authenticated" in line for line in lines), lines
    assert not server.workers()  # nothing was loaded
    served_fine(server, fmus, token)


def transport_frame(body: bytes) -> bytes:
    return struct.pack("<I", len(body)) + body


@pytest.mark.parametrize("sends, why", [
    (None, "no request for an FMU within 1 s"),  # proves the secret, then waits
    (struct.pack("<I", GIGABYTE), f"a frame of {GIGABYTE} bytes announced, at most 4096 accepted"),
    (transport_frame(b"J" + b"\xff" * 40), "malformed J message"),
    ("unknown", "no FMU NotThere in the served folder"),
    ("other guid", "the master's has {00000000-"),
    ("ahead", "it sent more than its request before the answer"),
    ("protocol 2", "protocol 2, this server speaks 3"),  # a client from before the init request's inputs
], ids=["waits", "1GB-frame", "garbage", "unknown-fmu", "other-guid", "sends-ahead", "old-protocol"])
def test_an_authenticated_client_that_does_not_name_a_served_fmu_is_refused(sends, why, fmus, token, server):
    md = read_fmu(fmus / "TiltloadController.fmu", "controller")
    sock = authenticated(server.address, token)
    if sends == "unknown":
        md.coSimulation.modelIdentifier = "NotThere"
    if sends == "other guid":
        md.guid = "{00000000-0000-0000-0000-000000000000}"
    if sends == "protocol 2":
        sends = transport_frame(open_request(md, protocol=2))
    if isinstance(sends, str):
        sends = transport_frame(open_request(md)) + (transport_frame(b"S" + bytes(16)) if sends == "ahead" else b"")
    if sends is not None:
        sock.sendall(sends)
    lines = refused(server, sock, why)
    assert not any("serving" in line for line in lines) and not server.workers()
    sock.close()
    served_fine(server, fmus, token)


def opened(server, token, md) -> tuple[socket.socket, Channel]:
    """A raw authenticated client whose FMU is instantiated on the server."""
    sock = authenticated(server.address, token)
    channel = Channel.over_socket(sock)
    channel.send(open_request(md))
    assert wire.decode_reply(channel.receive(5)).get("ok")
    assert wire.decode_reply(channel.receive(30)).get("ok")  # the worker's greeting: instantiated
    return sock, channel


@pytest.mark.parametrize("request_, why", [
    (struct.pack("<I", GIGABYTE), f"refused a frame of {GIGABYTE} bytes announced"),
    (transport_frame(wire.encode_step([("Real", 1, struct.pack("<I", 999999), struct.pack("<d", 1.0))], 0.0, 0.012)),
     "protocol error: a step sets a Real that is not an input of this model"),
    (transport_frame(b"S" + struct.pack("<dd", 0.0, 0.012) + b"R\x05\x00\x00\x00" + bytes(3)),
     "protocol error: a step announces 5 Real values and ends before them"),
    (transport_frame(wire.control({"op": "rm -rf"})), "protocol error: unknown request 'rm -rf'"),
    (transport_frame(wire.STATE + struct.pack("<Q", 10**6) + bytes(8)),
     "protocol error: a state announces 1000000 bytes and the message has 8"),
], ids=["1GB-frame", "not-an-input", "truncated", "unknown-op", "truncated-state"])
def test_a_session_that_sends_what_the_model_cannot_take_ends_and_the_server_goes_on(request_, why, fmus, token, server):
    md = read_fmu(fmus / "TiltloadController.fmu", "controller")
    sock, channel = opened(server, token, md)
    sock.sendall(request_)
    line = server.wait_for(why)
    assert "session ended" in line
    server.wait_for("session ended (controller: exit 1)")
    assert closed_by_server(sock)
    channel.close()
    served_fine(server, fmus, token)


def test_a_remote_fmu_state_travels_both_ways_and_the_fmu_refuses_bytes_not_its_own(fmus, token, server):
    """Snapshots of a remote instance: get_state comes back as the FMU serialized it, set_state puts it back (the
    outputs follow); bytes that are not a state of this build are the FMU's one-line refusal, and the session goes on."""
    md = read_fmu(fmus / "TiltloadController.fmu", "controller")
    local = IsolatedFmu("controller", fmus / "TiltloadController.fmu", md)  # the same FMU in a worker on pipes
    inst = remote_fmu("controller", fmus / "TiltloadController.fmu", md, server.address, token)
    try:
        for fmu in (local, inst):
            fmu.initialize({})
            fmu.do_step(0.0, 0.012)
        state = inst.get_state()
        assert state == local.get_state() and len(state) > 1000
        inst.do_step(0.012, 0.012)
        with pytest.raises(ExecutionError, match="not a state of this TiltloadController build"):
            inst.set_state(b"garbage" * 10)
        inst.set_state(state)
        local.do_step(0.012, 0.012)
        inst.do_step(0.012, 0.012)  # the step after the restored state, again: the same outputs as a local worker's
        assert all((inst.values[t] == local.values[t]).all() for t in inst.values)
    finally:
        inst.close()
        local.close()
    server.wait_for("session ended (controller: exit 0)")


def test_one_client_per_fmu_unless_configured(fmus, token, server):
    md = read_fmu(fmus / "TiltloadController.fmu", "controller")
    first = remote_fmu("controller", fmus / "TiltloadController.fmu", md, server.address, token)
    try:
        with pytest.raises(ExecutionError, match="TiltloadController.fmu is serving 1 client.s. already"):
            remote_fmu("controller", fmus / "TiltloadController.fmu", md, server.address, token)
        other = remote_fmu("sensors", fmus / "TiltloadSensors.fmu", read_fmu(fmus / "TiltloadSensors.fmu", "sensors"),
                           server.address, token)  # another FMU of the folder is free
        other.close()
    finally:
        first.close()
    server.wait_for("session ended (controller: exit 0)")
    served_fine(server, fmus, token)


def test_a_server_can_serve_two_clients_of_one_fmu_when_told(fmus, token):
    srv = ServerProcess(fmus, token, "--clients-per-fmu", "2")
    try:
        md = read_fmu(fmus / "TiltloadController.fmu", "controller")
        two = [remote_fmu("controller", fmus / "TiltloadController.fmu", md, srv.address, token) for _ in range(2)]
        assert len(srv.workers()) == 2
        for inst in two:
            inst.close()
    finally:
        srv.stop()


def test_an_fmu_built_for_the_board_keeps_its_guid_and_is_not_loaded_on_another_processor(fmus, token, tmp_path):
    """docs/remote.md: one FMU for desktop and board (binaries/linux64 and binaries/aarch64-linux, the same GUID); each
    machine loads its own library, and a server with only another processor's library refuses it in one line."""
    full = fmus / "TiltloadController.fmu"
    with zipfile.ZipFile(full) as z:
        names = z.namelist()
    if "binaries/aarch64-linux/TiltloadController.so" not in names:
        pytest.skip("the FMUs were built without the aarch64 cross compiler (tiltload build --platforms)")
    assert library_member(names, "TiltloadController", "aarch64-linux") == "binaries/aarch64-linux/TiltloadController.so"
    assert library_member(names, "TiltloadController", "x86_64-linux") == "binaries/linux64/TiltloadController.so"
    assert library_machine(full, "TiltloadController") == this_machine()  # what this machine loads of it
    served = tmp_path / "board"
    served.mkdir()
    board = board_copy(full, served / "TiltloadController.fmu")
    md = read_fmu(full, "controller")
    assert read_fmu(board, "controller").guid == md.guid
    assert library_machine(board, "TiltloadController") == "aarch64"
    if this_machine() == "aarch64":
        pytest.skip("this machine is the board")
    srv = ServerProcess(served, token)
    try:
        with pytest.raises(ExecutionError, match="TiltloadController.fmu here holds a library for aarch64, this machine is "
                                                 f"{this_machine()}: build the FMU for it"):
            remote_fmu("controller", full, md, srv.address, token)
        srv.wait_for("refused: TiltloadController.fmu here holds a library for aarch64")
        assert not srv.workers()
    finally:
        srv.stop()


def test_a_token_file_others_can_read_or_too_short_is_one_line(tmp_path):
    loose = token_file(tmp_path, "loose")
    loose.chmod(0o644)
    with pytest.raises(DescriptionError, match=r"can be read by other users \(chmod 600"):
        handshake.read_token(loose)
    short = tmp_path / "short"
    short.write_text("abc\n")
    short.chmod(0o600)
    with pytest.raises(DescriptionError, match="holds 3 bytes; a secret of at least 16"):
        handshake.read_token(short)


@pytest.fixture(scope="module")
def misbehaving_served(tmp_path_factory, token):
    """A folder with `tiltload wrap` controllers that hang or crash at t = 0.5 s, and a server for it."""
    folder = tmp_path_factory.mktemp("served")
    fmus = wrap_misbehaving(folder, {"hang": "time.sleep(3600)", "segfault": "os.kill(os.getpid(), signal.SIGSEGV)"}, 0.5)
    srv = ServerProcess(folder, token)
    yield fmus, srv
    srv.stop()


@pytest.mark.slow
def test_a_remote_fmu_that_hangs_trips_the_watchdog_and_the_server_kills_it(fmus, token, misbehaving_served):
    bad, srv = misbehaving_served
    system = default_system(fmus, "fsi", 1, controller_fmu=bad["hang"])
    ctrl = system.instance("controller")
    ctrl.remote, ctrl.token_file = srv.address, token
    ex = Execution(system, [loop_metrics()], step_timeout=1.0)
    ex.instantiate()
    try:
        with pytest.raises(ExecutionError, match=r"controller: doStep at t=0\.504 s did not return within 1 s \(watchdog; "
                                                 r"--step-timeout sets the limit\): the connection to .* was closed"):
            ex.run(2.0)
    finally:
        ex.close()
    assert "still busy (hung?): killed" in srv.wait_for("the client left")
    srv.wait_for("session ended")
    assert not srv.workers()


def test_a_remote_fmu_that_crashes_is_one_line_and_the_server_survives(fmus, token, misbehaving_served):
    bad, srv = misbehaving_served
    system = default_system(fmus, "fsi", 1, controller_fmu=bad["segfault"])
    ctrl = system.instance("controller")
    ctrl.remote, ctrl.token_file = srv.address, token
    ex = Execution(system, [loop_metrics()])
    ex.instantiate()
    try:
        with pytest.raises(ExecutionError, match=r"controller: the FMU crashed \(SIGSEGV\) in doStep at t=0\.504 s "
                                                 r"on tiltload serve at 127"):
            ex.run(2.0)
    finally:
        ex.close()
    assert "killed by signal 11" in srv.wait_for("session ended")
    assert srv.proc.poll() is None  # the server lives on


def test_the_link_reports_a_closed_peer_and_an_oversized_frame():
    a, b = socket.socketpair()
    left, right = Channel.over_socket(a), Channel.over_socket(b)
    left.send(b"x" * 100)
    with pytest.raises(FrameTooLarge, match="a frame of 100 bytes announced, at most 10 accepted"):
        right.receive(1, limit=10)  # told from the header alone: the link is then for closing
    assert right.receive(1) == b"x" * 100
    left.send(b"last")
    left.close()
    assert right.receive(1) == b"last"  # what came before the end is delivered, then the end
    with pytest.raises(LinkClosed):
        right.receive(1)
    right.close()


def test_a_server_that_is_not_there_is_one_line(fmus, token):
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]  # free once closed
    md = read_fmu(fmus / "TiltloadController.fmu", "controller")
    started = time.monotonic()
    with pytest.raises(ExecutionError, match=rf"controller: tiltload serve at 127.0.0.1:{port}: cannot connect \(Connection refused\)"):
        remote_fmu("controller", fmus / "TiltloadController.fmu", md, f"127.0.0.1:{port}", token)
    assert time.monotonic() - started < 5


def test_deeply_nested_json_after_the_handshake_is_refused_in_one_line_and_no_traceback(fmus, token, server):
    """Issue 37: 4,000 open brackets in the request for an FMU, and 100,000 in a session's request: each is refused
    by its nesting before it is parsed (no RecursionError in the admission thread or the worker); the client gets the
    refusal, the server goes on."""
    sock = authenticated(server.address, token)
    channel = Channel.over_socket(sock)
    channel.send(b"J" + b"[" * 4000)
    reply = wire.decode_reply(channel.receive(5))
    assert (reply["error"], reply["message"]) == ("refused", "malformed J message (JSON nested deeper than 16)")
    refused(server, sock, "malformed J message (JSON nested deeper than 16)")
    sock.close()
    md = read_fmu(fmus / "TiltloadController.fmu", "controller")
    sock, channel = opened(server, token, md)
    channel.send(b"J" + b"[" * 100_000)
    reply = wire.decode_reply(channel.receive(5))
    assert (reply["error"], reply["message"]) == ("protocol", "malformed J message (JSON nested deeper than 16)")
    assert "session ended" in server.wait_for("malformed J message (JSON nested deeper than 16)")
    channel.close()
    served_fine(server, fmus, token)
    assert not any("Traceback" in line or "RecursionError" in line for line in server.lines), server.lines

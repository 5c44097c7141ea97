"""The controller's per-step round trip: in this process, in a local worker (pipes), on `tiltload serve` over TCP.

The thesis's loop (ZSE scenario, mixed design: the heaviest controller step) with our controller
hosted four ways: in the master's process; in a worker process on a pipe pair (isolation/process.py);
on a `tiltload serve` on this machine over loopback TCP; and, when run as root with iproute2, on
a `tiltload serve` in a network namespace of its own reached through a veth pair (a link with a
real, if short, network path). Printed: the controller's microseconds per step inside the master's
calls (set inputs + doStep + outputs: the round trip included), best of three runs, the loop's
real-time factor, and whether the metrics are the in-process ones bit for bit. No log is written.

Run: python benchmarks/remote.py [stop]   (default 20 s of simulated time)
"""

from __future__ import annotations

import os
import platform
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # the server helpers of the test suite

from support.remote import Namespace, ServerProcess, netns_available, token_file  # noqa: E402
from tiltload.master.app.loop.fmus import build_all  # noqa: E402
from tiltload.master.app.loop.thesis import TICK, default_system, loop_metrics  # noqa: E402
from tiltload.master.engine.execution import Execution  # noqa: E402
from tiltload.master.engine.isolation.transport import Channel  # noqa: E402


def timed(fmus: Path, scenario: str, stop: float, isolate=None, remote: str | None = None, token: Path | None = None):
    system = default_system(fmus, scenario, 1, "mixed")
    ctrl = system.instance("controller")
    ctrl.remote, ctrl.token_file = remote, token
    ex = Execution(system, [loop_metrics()], isolate=isolate, profile=True)
    ex.instantiate()
    for inst in ex.instances.values():
        inst.fmi_seconds = 0.0
    started = time.perf_counter()
    ex.run(stop)
    wall = time.perf_counter() - started
    per_step = ex.instances["controller"].fmi_seconds / ex.ticks_done
    metrics = ex.observers[0].table()
    ex.close()
    return per_step, wall, metrics


ECHO = """
import socket, sys
from tiltload.master.engine.isolation.transport import Channel
kind, arg = sys.argv[1], sys.argv[2]
if kind == "pipes":
    r, w = map(int, arg.split(","))
    channel = Channel.over_pipes(r, w)
else:
    host, port = arg.rsplit(":", 1)
    channel = Channel.over_socket(socket.create_connection((host, int(port))))
reply = bytes(int(sys.argv[3]))
try:
    while True:
        channel.receive()
        channel.send(reply)
except Exception:
    pass
"""


def link_round_trip(kind: str, request: int, reply: int, n: int = 3000, netns: str | None = None,
                    listen: str = "127.0.0.1") -> list[float]:
    """Seconds per round trip of a request and a reply of these sizes (a step's), with nothing computed: the link alone,
    Python on both ends as in a run. kind: pipes or tcp."""
    prefix = ["ip", "netns", "exec", netns] if netns else []
    if kind == "pipes":
        req_r, req_w = os.pipe()
        rep_r, rep_w = os.pipe()
        proc = subprocess.Popen([sys.executable, "-c", ECHO, "pipes", f"{req_r},{rep_w}", str(reply)], pass_fds=(req_r, rep_w))
        os.close(req_r)
        os.close(rep_w)
        channel = Channel.over_pipes(rep_r, req_w)
    else:
        listener = socket.create_server((listen, 0))
        proc = subprocess.Popen([*prefix, sys.executable, "-c", ECHO, "tcp", f"{listen}:{listener.getsockname()[1]}", str(reply)])
        channel = Channel.over_socket(listener.accept()[0])
        listener.close()
    payload, times = bytes(request), []
    for _ in range(n):
        started = time.perf_counter()
        channel.send(payload)
        channel.receive(10)
        times.append(time.perf_counter() - started)
    channel.close()
    proc.wait(timeout=10)
    return times[100:]  # without the first: caches, page faults


def step_sizes(fmus: Path) -> tuple[int, int]:
    """The bytes of the controller's step request and reply in the loop (wire.py): what the link carries per tick."""
    from tiltload.master.engine.fmi.model_description import read_fmu
    from tiltload.master.engine.isolation import wire

    md = read_fmu(fmus / "TiltloadController.fmu", "controller")
    inputs = [v for v in md.modelVariables if v.causality == "input"]
    outputs = {t: sum(v.causality == "output" and v.type == t for v in md.modelVariables) for t in wire.TYPES}
    request = 1 + 16 + sum(5 + (4 + wire.WIDTH[t]) * sum(v.type == t for v in inputs) for t in wire.TYPES
                           if any(v.type == t for v in inputs))
    return request + 4, 1 + wire.output_bytes(outputs) + 4


def machine() -> str:
    cpu = next((line.split(":", 1)[1].strip() for line in Path("/proc/cpuinfo").read_text().splitlines()
                if line.startswith("model name")), platform.processor())
    return f"{cpu}, {os.cpu_count()} cores, Linux {platform.release()}, Python {platform.python_version()}"


def main() -> int:
    stop = float(sys.argv[1]) if len(sys.argv) > 1 else 10.0
    rounds = 5
    print(f"machine: {machine()}; load average {os.getloadavg()[0]:.1f} at the start")
    print(f"loop: trajectory 1, mixed design, {stop:g} s = {round(stop / TICK)} ticks; {rounds} rounds, the hosts interleaved\n")
    with tempfile.TemporaryDirectory() as tmp:
        fmus = Path(tmp) / "fmus"
        build_all(fmus, progress=lambda *_: None)
        controller = fmus / "TiltloadController.fmu"
        token = token_file(Path(tmp))
        hosts = [("in process", {}), ("local worker (pipes)", {"isolate": lambda fmu, md: Path(fmu) == controller})]
        servers, namespace = [ServerProcess(fmus, token)], None
        hosts.append(("tiltload serve, loopback TCP", {"remote": servers[0].address, "token": token}))
        if netns_available():
            namespace = Namespace()
            servers.append(ServerProcess(fmus, token, bind=f"{namespace.server_ip}:0", netns=namespace.name))
            hosts.append(("tiltload serve, other netns (veth)", {"remote": servers[1].address, "token": token}))
        ok = True
        try:
            request, reply = step_sizes(fmus)
            print(f"the link alone: about {request} bytes out, {reply} back per step (the controller's), Python at both ends, "
                  "nothing computed; microseconds per round trip, median / p99 of 2900")
            links = [("pipes", {}), ("loopback TCP", {"kind": "tcp"})]
            if namespace is not None:
                links.append(("veth to another netns", {"kind": "tcp", "netns": namespace.name, "listen": namespace.master_ip}))
            for label, how in links:
                times = sorted(link_round_trip(how.pop("kind", "pipes"), request, reply, **how))
                print(f"  {label:<36} {1e6 * statistics.median(times):7.1f} / {1e6 * times[int(0.99 * len(times))]:7.1f}")
            print()
            for scenario, what in (("fsi", "the lightest step: no estimator"), ("zse", "the heaviest: the ZSE")):
                runs: dict[str, list] = {label: [] for label, _ in hosts}
                for _ in range(rounds):
                    for label, how in hosts:
                        runs[label].append(timed(fmus, scenario, stop, **how))
                print(f"{scenario.upper()} ({what}): the controller's microseconds per step, min / median of {rounds}")
                base = min(r[0] for r in runs["in process"])
                reference = runs["in process"][0][2]
                for label, results in runs.items():
                    steps = [r[0] for r in results]
                    same = all(r[2] == reference for r in results)
                    ok &= same
                    extra = "" if label == "in process" else f", +{1e6 * (min(steps) - base):6.1f} us over in process"
                    print(f"  {label:<36} {1e6 * min(steps):7.1f} / {1e6 * statistics.median(steps):7.1f}{extra}; "
                          f"loop {stop / min(r[1] for r in results):5.0f}x real time; metrics "
                          f"{'= in process, bit for bit' if same else 'DIFFER'}")
                print()
        finally:
            for server in servers:
                server.stop()
            if namespace is not None:
                namespace.remove()
        print(f"load average {os.getloadavg()[0]:.1f} at the end (2 cores: above 2, other work competed for them)")
        return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())

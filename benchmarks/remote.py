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
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # the server helpers of the test suite

from support.remote import Namespace, ServerProcess, netns_available, remote_execution, token_file  # noqa: E402
from tiltload.master.app.fmus import build_all  # noqa: E402
from tiltload.master.app.loop import TICK, default_system, loop_metrics  # noqa: E402
from tiltload.master.engine.execution import Execution  # noqa: E402


def timed(fmus: Path, scenario: str, stop: float, isolate=None, remote: str | None = None, token: Path | None = None):
    system = default_system(fmus, scenario, 1, "mixed")
    ctrl = system.instance("controller")
    ctrl.remote, ctrl.token_file = remote, token
    with remote_execution():
        ex = Execution(system, [loop_metrics()], isolate=isolate)
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

"""The controller hosted three ways, FMI 2.0 beside FMI 3.0 (plain and with clocks), side by side in one run.

The thesis's loop (ZSE scenario, mixed design) with our controller in the master's process, in a worker process on
a pipe pair, and on a `tiltload serve` on loopback TCP, for the FMI 2.0 FMUs, the plain FMI 3.0 ones and the clocked
FMI 3.0 ones. Printed: the controller's microseconds per tick inside the master's calls (for a hosted one the round
trip included; for a clocked one the Event Mode, the clocks and the discrete-state update included), best of
`repeats` runs; the loop's real-time factor; and whether the metrics equal the same FMI version's in-process ones
bit for bit (and the FMI 2.0 ones). No log is written.

Run: python benchmarks/fmi3_hosted.py [stop] [repeats]   (default 10 s of simulated time, 3 runs)
"""

from __future__ import annotations

import platform
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # the server helpers of the test suite

from support.remote import ServerProcess, token_file  # noqa: E402
from tiltload.master.app.loop.fmus import build_all, fmu_folder  # noqa: E402
from tiltload.master.app.loop.thesis import default_system, loop_metrics  # noqa: E402
from tiltload.master.engine.execution import Execution  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
VARIANTS = {"FMI 2.0": (2, False), "FMI 3.0": (3, False), "FMI 3.0 clocked": (3, True)}


def hosted_controller(fmu: Path, md) -> bool:
    return fmu.stem.startswith("TiltloadController")


def timed(folder: Path, fmi: int, clocked: bool, stop: float, where: str, address: str | None, token: Path):
    system = default_system(folder, "zse", 1, "mixed", fmi=fmi if fmi == 3 else None, clocked=clocked)
    if where == "tiltload serve":
        ctrl = system.instance("controller")
        ctrl.remote, ctrl.token_file = address, token
    ex = Execution(system, [loop_metrics()], isolate=hosted_controller if where == "worker" else None, profile=True)
    ex.instantiate()
    try:
        for inst in ex.instances.values():
            inst.fmi_seconds = 0.0
        started = time.perf_counter()
        ex.run(stop)
        wall = time.perf_counter() - started
        return ex.instances["controller"].fmi_seconds / ex.ticks_done, wall, ex.observers[0].table()
    finally:
        ex.close()


def main() -> None:
    stop = float(sys.argv[1]) if len(sys.argv) > 1 else 10.0
    repeats = int(sys.argv[2]) if len(sys.argv) > 2 else 3
    base = ROOT / "fmus"
    build_all(base, progress=lambda *_: None)
    for clocked in (False, True):
        build_all(fmu_folder(base, 3), progress=lambda *_: None, fmi_version=3, clocked=clocked)
    token = token_file(Path(tempfile.mkdtemp()))
    servers = {2: ServerProcess(base, token), 3: ServerProcess(fmu_folder(base, 3), token)}
    print(f"{platform.processor() or platform.machine()}, Python {platform.python_version()}; ZSE, mixed, {stop:g} s "
          f"simulated, best of {repeats}")
    print(f"{'variant':<16} {'host':<15} {'us/tick':>9} {'x real time':>12}  metrics")
    reference = {}
    try:
        for variant, (fmi, clocked) in VARIANTS.items():
            folder = base if fmi == 2 else fmu_folder(base, 3)
            for where in ("in process", "worker", "tiltload serve"):
                runs = [timed(folder, fmi, clocked, stop, where, servers[fmi].address, token) for _ in range(repeats)]
                per_tick = min(r[0] for r in runs)
                wall = min(r[1] for r in runs)
                metrics = runs[0][2]
                same = all(r[2] == metrics for r in runs)
                reference.setdefault(variant, metrics)
                reference.setdefault("FMI 2.0", metrics)
                verdict = ("= in process" if metrics == reference[variant] else "DIFFERS from in process") + \
                          (", = FMI 2.0" if metrics == reference["FMI 2.0"] else ", differs from FMI 2.0") + \
                          ("" if same else "; runs differ")
                print(f"{variant:<16} {where:<15} {per_tick * 1e6:>9.1f} {stop / wall:>11.0f}x  {verdict}")
    finally:
        for srv in servers.values():
            srv.stop()


if __name__ == "__main__":
    main()

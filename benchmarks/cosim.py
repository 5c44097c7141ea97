"""Loop throughput per scenario: tiltload's master with a full log, with no log, and libcosim on the same FMUs.

Per scenario (trajectory 1, mixed design), printed: real-time factor with the full MCAP log (as
`tiltload run`) and with no log (metrics only, as campaigns); the master's own microseconds per
tick (wall time outside the FMI calls, full log); each FMU's microseconds per tick (its FMI calls,
marshalling included); and the same four FMUs in libcosim (libcosimpy, same process, fixed step
12 ms, no observer but the last-value one) with the ratio of tick costs. libcosim is a Jacobi
master: it runs the SSP package `tiltload ssp export` writes for it (designs for the 2-tick loop
delay it adds, docs/ports.md), and ours runs the same package the same way (master/jacobi.py), no
log, over the whole run. Targets: FSI >= 100x full log and >= 250x no log, ZSE >= 40x full log,
master <= 50 us per tick with the full log, no-log master at least as fast as libcosim.

Run: pip install -e ".[bench]" && python benchmarks/cosim.py [stop]
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

from tiltload.controller_fmu.design.cache import cache_root
from tiltload.master.app.fmus import build_all
from tiltload.master.app.loop import default_system, loop_metrics
from tiltload.master.app.scene import scene_channels
from tiltload.master.engine import jacobi, ssp
from tiltload.master.engine.mcap_log import McapLogger
from tiltload.master.engine.model_description import read_fmu
from timing import timed_run

UNPACK = cache_root() / "ssp"  # where packages are unpacked, as tiltload run does
TICK = 0.012


def ours(system, stop: float, log: Path | None) -> tuple[float, dict[str, float]]:
    observers = [loop_metrics()]
    if log is not None:
        observers.insert(0, McapLogger(log, derived=scene_channels("plant")))
    return timed_run(system, stop, observers)


def libcosim(package: Path, stop: float) -> float | None:
    """Wall time of the package in libcosim (None if libcosimpy is not installed or the run fails)."""
    try:
        from libcosimpy.CosimExecution import CosimExecution
        from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
        from libcosimpy.CosimObserver import CosimObserver
    except ImportError:
        return None
    log_output_level(CosimLogLevel.ERROR)
    ex = CosimExecution.from_ssp_file(str(package))
    ex.add_observer(CosimObserver.create_last_value())
    t0 = time.perf_counter()
    ok = ex.simulate_until(int(round(stop / TICK)) * int(TICK * 1e9))
    wall = time.perf_counter() - t0
    return wall if ok else None


def jacobi_package(fmus: Path, scenario: str, folder: Path, stop: float):
    """The loop as the package a Jacobi master runs, and the same system for ours."""
    system = default_system(fmus, scenario, 1, "mixed")
    system.instance("controller").parameters["loop_delay_ticks"] = 2
    package = ssp.export(system, folder / f"{scenario}.ssp", stop, "jacobi")
    loaded, _, _ = ssp.load(package, UNPACK)
    return package, jacobi.explicit(loaded, {i.name: read_fmu(i.fmu, i.name) for i in loaded.instances}, jacobi=True)


def main() -> None:
    stop = float(sys.argv[1]) if len(sys.argv) > 1 else 20.0
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    fmus = Path("fmus")
    build_all(fmus)
    ticks = round(stop / TICK)
    print(f"{stop:g} s of trajectory 1 per run, mixed H2/Hinf design; libcosim and ours no-log on the Jacobi package\n")
    print(f"{'scenario':>8} {'x RT log':>9} {'x RT no log':>12} {'master us/tick':>15} {'per FMU us/tick (full log)':>40}"
          f" {'libcosim us/tick':>17} {'ours no log':>12} {'ratio':>6} {'log MB/s sim':>13}")
    with tempfile.TemporaryDirectory() as tmp:
        for scenario in ("fsi", "lkf", "zse"):
            system = default_system(fmus, scenario, 1, "mixed")
            log = Path(tmp) / f"{scenario}.mcap"
            wall, fmi = ours(system, stop, log)
            wall_nolog, _ = ours(system, stop, None)
            master_us = (wall - sum(fmi.values())) / ticks * 1e6
            per = " ".join(f"{n[:4]} {s / ticks * 1e6:.1f}" for n, s in fmi.items())
            package, jacobi_system = jacobi_package(fmus, scenario, Path(tmp), stop)
            ours_jacobi, _ = ours(jacobi_system, stop, None)
            lc = libcosim(package, stop)
            lc_text = f"{lc / ticks * 1e6:>17.1f}" if lc else f"{'n/a':>17}"
            ratio = f"{lc / ours_jacobi:>6.2f}" if lc else f"{'n/a':>6}"
            print(f"{scenario:>8} {stop / wall:>9.1f} {stop / wall_nolog:>12.1f} {master_us:>15.1f} {per:>40}"
                  f" {lc_text} {ours_jacobi / ticks * 1e6:>12.1f} {ratio} {log.stat().st_size / 1e6 / stop:>13.3f}")
    print("\nratio = libcosim's time per tick / ours with no log (> 1: ours is faster); the JSON log before: 0.165 MB/s (ZSE)")


if __name__ == "__main__":
    main()

"""The formation's speed: seven FMU instances (formation controller, three trackers, three UAV plants) at 4 ms.

Per formation controller, with and without disturbances: the real-time factor of 60 s with the full
MCAP log (three 3D scenes) and with no log, the master's own microseconds per tick (outside the FMI
calls) and each FMU's microseconds per tick (its FMI calls, marshalling included).

Run: python benchmarks/formation.py [stop]
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

from tiltload.formation.kinematics import AGENTS
from tiltload.master.app.formation.system import formation_system
from tiltload.master.app.loop.fmus import build_formation as build_fmus
from tiltload.master.app.loop.scene import scene_channels
from tiltload.master.engine.log.logger import McapLogger
from timing import timed_run


def timed(system, stop: float, log: Path | None):
    return timed_run(system, stop, [McapLogger(log, derived=scene_channels(tuple(f"plant_{a}" for a in AGENTS)))] if log else [])


def main() -> None:
    stop = float(sys.argv[1]) if len(sys.argv) > 1 else 60.0
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    fmus = Path("fmus")
    build_fmus(fmus, progress=lambda *_: None)
    print(f"{stop:g} s per run, 4 ms tick ({round(stop / 0.004)} ticks), 7 FMU instances\n")
    print(f"{'case':>24} {'x RT log':>9} {'x RT no log':>12} {'master us/tick':>15}   per FMU us/tick (full log)")
    with tempfile.TemporaryDirectory() as tmp:
        for controller in ("backstepping", "tsid"):
            for disturbed in (False, True):
                system = formation_system(fmus, controller, disturbed)
                ticks = round(stop / system.tick)
                wall, fmi = timed(system, stop, Path(tmp) / "run.mcap")
                wall_nolog, _ = timed(system, stop, None)
                master = (wall - sum(fmi.values())) / ticks * 1e6
                per = " ".join(f"{n.replace('tracker_', 'tr_').replace('plant_', 'pl_')[:8]} {s / ticks * 1e6:.1f}"
                               for n, s in fmi.items())
                case = f"{controller}{' disturbed' if disturbed else ''}"
                print(f"{case:>24} {stop / wall:>9.1f} {stop / wall_nolog:>12.1f} {master:>15.1f}   {per}", flush=True)


if __name__ == "__main__":
    main()

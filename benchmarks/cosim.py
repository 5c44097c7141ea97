"""Wall time, real-time factor and the master's share of each scenario (DESIGN §4; targets FSI >= 100x, ZSE >= 30x, master <= 10 %).

The master's share is the wall time outside FMI calls (scheduling, transfers, observers),
with the MCAP logger and metrics on, as in `tiltload run`. Run: python benchmarks/cosim.py [stop]
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

from tiltload.master.build_all import build_all
from tiltload.master.execution import Execution
from tiltload.master.mcap_log import McapLogger
from tiltload.master.observers import Metrics
from tiltload.master.tiltload_system import default_system


def main() -> None:
    stop = float(sys.argv[1]) if len(sys.argv) > 1 else 20.0
    fmus = Path("fmus")
    build_all(fmus)
    print(f"{stop:g} s of trajectory 1 per run, mixed H2/Hinf controller, MCAP logging on\n")
    print(f"{'scenario':>8} {'wall s':>7} {'x real time':>12} {'ms/tick':>8} {'master %':>9}   per FMU (ms/tick)")
    with tempfile.TemporaryDirectory() as tmp:
        for scenario in ("fsi", "lkf", "zse"):
            system = default_system(fmus, scenario, 1, "mixed")
            ex = Execution(system, [McapLogger(Path(tmp) / f"{scenario}.mcap", scene_from="plant"),
                                    Metrics("plant", "scenario", "controller")])
            ex.instantiate()
            for inst in ex.instances.values():
                inst.fmi_seconds = 0.0
            t0 = time.perf_counter()
            ex.run(stop)
            wall = time.perf_counter() - t0
            fmi = {n: i.fmi_seconds for n, i in ex.instances.items()}
            ex.close()
            ticks = round(stop / system.tick)
            per = "  ".join(f"{n} {s / ticks * 1e3:.2f}" for n, s in fmi.items())
            print(f"{scenario:>8} {wall:>7.2f} {stop / wall:>12.1f} {wall / ticks * 1e3:>8.2f} "
                  f"{100 * (wall - sum(fmi.values())) / wall:>9.1f}   {per}")


if __name__ == "__main__":
    main()

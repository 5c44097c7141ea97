"""The loop on FMI 2.0, plain FMI 3.0 and clocked FMI 3.0 FMUs, side by side: wall time, the master's overhead, same bits.

Each set runs the ZSE scenario (trajectory 1, mixed design) without a log, several rounds interleaved so the
machine's load touches every set alike; printed: the best wall time, the microseconds per tick spent in the
FMUs' FMI calls and outside them (the master's own work), and whether the metrics are the same bits as FMI
2.0's. The clocked set runs Event Mode at every tick for the sensors and the controller (fmi3EnterEventMode,
fmi3SetClock, clocked gets, fmi3UpdateDiscreteStates, fmi3EnterStepMode besides the step).

Run: python benchmarks/fmi3.py [stop] [rounds]   (FMUs built into a temporary folder)
"""

from __future__ import annotations

import platform
import sys
import tempfile
import time
from pathlib import Path

from tiltload.master.app.fmus import build_all, fmu_folder
from tiltload.master.app.loop import default_system, loop_metrics
from tiltload.master.engine.execution import Execution


def timed(system, stop: float) -> tuple[float, float, dict]:
    metrics = loop_metrics()
    ex = Execution(system, [metrics], profile=True)
    ex.instantiate()
    for inst in ex.instances.values():
        inst.fmi_seconds = 0.0
    t0 = time.perf_counter()
    ex.run(stop)
    wall = time.perf_counter() - t0
    fmi = sum(inst.fmi_seconds for inst in ex.instances.values())
    ex.close()
    return wall, fmi, metrics.table()


def main() -> int:
    stop = float(sys.argv[1]) if len(sys.argv) > 1 else 40.0
    rounds = int(sys.argv[2]) if len(sys.argv) > 2 else 3
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(tmp) / "fmus"
        say = lambda m: print(f"  {m}", file=sys.stderr)  # noqa: E731
        build_all(base, progress=say)
        build_all(fmu_folder(base, 3), progress=say, fmi_version=3)
        build_all(fmu_folder(base, 3), progress=say, fmi_version=3, clocked=True)
        sets = {"FMI 2.0": default_system(base, "zse", 1, "mixed"),
                "FMI 3.0 plain": default_system(fmu_folder(base, 3), "zse", 1, "mixed", fmi=3),
                "FMI 3.0 clocks": default_system(fmu_folder(base, 3), "zse", 1, "mixed", fmi=3, clocked=True)}
        best: dict[str, tuple] = {}
        for _ in range(rounds):
            for label, system in sets.items():
                r = timed(system, stop)
                if label not in best or r[0] < best[label][0]:
                    best[label] = r
    ticks = round(stop / 0.012)
    print(f"machine: {platform.node()} {platform.machine()} {platform.processor() or ''} ({sys.version.split()[0]}); "
          f"{stop:g} s = {ticks} ticks, best of {rounds}")
    print(f"{'FMU set':>16} {'wall s':>8} {'x real time':>12} {'FMI us/tick':>12} {'master us/tick':>15}  metrics")
    reference = best["FMI 2.0"][2]
    for label, (wall, fmi, metrics) in best.items():
        same = "same bits" if metrics == reference else "DIFFER"
        print(f"{label:>16} {wall:8.2f} {stop / wall:12.0f} {fmi / ticks * 1e6:12.1f} {(wall - fmi) / ticks * 1e6:15.1f}  {same}")
    return 0 if all(m == reference for _, _, m in best.values()) else 1


if __name__ == "__main__":
    sys.exit(main())

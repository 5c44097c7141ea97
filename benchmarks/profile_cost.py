"""What `tiltload run --profile` costs: the thesis's loop (all four FMUs in this process, no log) per tick with the
profile off and on, runs interleaved, the best of --repeats each; the machine's load average beside the figures.

Run: python benchmarks/profile_cost.py [--scenario lkf] [--stop 20] [--repeats 5]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

from tiltload.master.app.loop.fmus import build_all
from tiltload.master.app.loop.thesis import default_system, loop_metrics
from tiltload.master.engine.execution import Execution
from tiltload.master.engine.profile import Profiler


def per_tick(fmus: Path, scenario: str, stop: float, profiled: bool) -> float:
    ex = Execution(default_system(fmus, scenario, 1, "mixed"), [loop_metrics()])
    ex.instantiate()
    try:
        profiler = Profiler(ex) if profiled else None
        if profiler is not None:
            profiler.start()
        started = time.perf_counter()
        ex.run(stop)
        wall = time.perf_counter() - started
        if profiler is not None:
            profiler.stop()
        return wall / ex.ticks_done
    finally:
        ex.close()


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    p.add_argument("--scenario", default="lkf")
    p.add_argument("--stop", type=float, default=20.0)
    p.add_argument("--repeats", type=int, default=5)
    args = p.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        fmus = Path(tmp) / "fmus"
        build_all(fmus, progress=lambda _: None)
        load = os.getloadavg()
        per_tick(fmus, args.scenario, 1.0, False)  # warm
        off, on = [], []
        for _ in range(args.repeats):
            off.append(per_tick(fmus, args.scenario, args.stop, False))
            on.append(per_tick(fmus, args.scenario, args.stop, True))
        print(f"load average {load[0]:.2f} -> {os.getloadavg()[0]:.2f} ({os.cpu_count()} cores)")
        print(f"{args.scenario}, {args.stop:g} s, best of {args.repeats}: profile off {min(off) * 1e6:.2f} µs a tick, "
              f"on {min(on) * 1e6:.2f} µs a tick ({(min(on) - min(off)) * 1e6:+.2f} µs)")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Campaign throughput on Dask: per-run set-up cost (fresh FMUs against fmi2Reset), scaling from 1 to 2 workers,
and the share of a campaign's time spent outside the simulations.

The campaign: ZSE scenario, trajectory 1, both designs, 24 seeds, 40 s per run (48 runs) on a
LocalCluster of 1, then 2 worker processes (one thread each). Rates count from the first submission
to the last result; the cluster's start (about a second) is printed apart. Targets: 2 workers >= 1.8x the runs
per second of 1 on a 2-core machine; time outside the simulations <= 5 %.
Run: python benchmarks/campaign.py
"""

from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path

import pyarrow.parquet as pq
from tiltload.master.app.campaign import runner as campaign
from tiltload.master.app.fmus import build_all
from tiltload.master.app.loop import default_system
from tiltload.master.engine.execution import Execution

SPEC = """
name = "scaling"
[base]
scenario = "zse"
trajectory = 1
controllers = ["dlqr", "mixed"]
stop_time = 40.0
[vary]
seeds = [{seeds}]
"""


def setup_costs(fmus: Path, n: int = 10) -> tuple[float, float]:
    system = default_system(fmus, "zse", 1, "mixed")
    t0 = time.perf_counter()
    for _ in range(n):
        ex = Execution(system)
        ex.instantiate()
        ex.close()
    fresh = (time.perf_counter() - t0) / n
    ex = Execution(system)
    ex.instantiate()
    t0 = time.perf_counter()
    for _ in range(n):
        ex.restart({i.name: dict(i.parameters) for i in system.instances})
    reset = (time.perf_counter() - t0) / n
    ex.close()
    return fresh, reset


def main() -> None:
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    fmus = Path("fmus")
    build_all(fmus)
    fresh, reset = setup_costs(fmus)
    print(f"per-run set-up of the four FMUs: instantiate {fresh * 1e3:.1f} ms, fmi2Reset + initialize {reset * 1e3:.2f} ms "
          f"(a 40 s ZSE run simulates in about 0.5 s)\n")
    with tempfile.TemporaryDirectory() as tmp:
        spec = Path(tmp) / "scaling.toml"
        spec.write_text(SPEC.format(seeds=", ".join(str(s) for s in range(1, 25))))
        rates = {}
        for workers in (1, 2):
            out = Path(tmp) / f"w{workers}"
            t0 = time.perf_counter()
            results, counts = campaign.run(spec, out, workers=workers, fmus=fmus, progress=lambda _: None)
            total = time.perf_counter() - t0
            wall = counts["seconds"]
            timings = pq.read_table(out / campaign.TIMINGS).to_pylist()
            busy = sum(t["wall_s"] for t in timings)
            rates[workers] = counts["ran"] / wall
            print(f"{workers} worker(s): {counts['ran']} runs in {wall:.1f} s = {rates[workers]:.2f} runs/s; "
                  f"time outside the simulations {100 * (1 - busy / (wall * workers)):.1f} %; "
                  f"with the cluster's start and stop {total:.1f} s")
        print(f"\nscaling 1 -> 2 workers: {rates[2] / rates[1]:.2f}x (target >= 1.8x)")


if __name__ == "__main__":
    main()

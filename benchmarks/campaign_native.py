"""Campaign throughput of the native tick loop: runs per second per worker against one run alone, for FSI and ZSE.

For each scenario (trajectory 1, mixed H2/Hinf design, 40 s per run, no log, the campaign's metrics), a campaign of
--runs seeds runs on the project's campaign runner (master/app/campaign/runner.py: a Dask LocalCluster of 1, then 2
worker processes, one thread each). Its rate counts from the first submission to the last result (the cluster's start
and stop apart, printed). One run alone is the mean wall time of the same cases run one after the other in this process
(warm, as a worker runs them: the FMUs instantiated once, fmi2Reset between runs), measured right before and right after
each campaign (a shared machine's load drifts). Parallel efficiency = (runs per second per worker) x (one run's wall
time): 1.0 when N workers each keep the pace of one run alone. The machine and its load are printed: on a machine other
work is using, efficiency on 2 workers says more about that work than about the runner.

Run: python benchmarks/campaign_native.py [--runs 16] [--stop 40] [--workers 1 2] [--quick]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from dataclasses import asdict
from pathlib import Path

import pyarrow.parquet as pq
from tiltload.master.app.campaign import runner
from tiltload.master.app.campaign.run_case import run_case
from tiltload.master.app.campaign.spec import load
from tiltload.master.app.fmus import build_all
from timing import machine

SPEC = """
name = "native-{scenario}"
[base]
scenario = "{scenario}"
trajectory = 1
controllers = ["mixed"]
stop_time = {stop!r}
[vary]
seeds = [{seeds}]
"""


def spec_file(folder: Path, scenario: str, stop: float, runs: int) -> Path:
    path = folder / f"{scenario}.toml"
    path.write_text(SPEC.format(scenario=scenario, stop=stop, seeds=", ".join(str(s) for s in range(1, runs + 1))))
    return path


def one_run_alone(spec: Path, fmus: Path, n: int) -> float:
    """Mean wall time of n of the campaign's cases run one after the other here, after one warm-up run; each must
    complete (a failed run would be fast and mean nothing)."""
    c = load(spec)
    base = {"scenario": c.scenario, "trajectory": c.trajectory, "stop_time": c.stop_time, "gusts": c.gusts,
            "keep_metrics": list(c.keep_metrics), "faults": c.faults}  # as the runner hands them to a worker
    cases = [asdict(case) for case in c.cases[:n + 1]]
    walls = []
    for k, case in enumerate(cases):
        t0 = time.perf_counter()
        result = run_case(base, case, str(fmus.resolve()), None)
        if not result["row"]["completed"]:
            raise SystemExit(f"run {case['run_id']} failed: {result['row']['error']}")
        if k:
            walls.append(time.perf_counter() - t0)
    return sum(walls) / len(walls)


def campaign(spec: Path, out: Path, fmus: Path, workers: int, alone_runs: int) -> dict:
    before = one_run_alone(spec, fmus, alone_runs)
    t0 = time.perf_counter()
    _, counts = runner.run(spec, out, workers=workers, fmus=fmus, progress=lambda _: None)
    total = time.perf_counter() - t0
    after = one_run_alone(spec, fmus, alone_runs)
    if counts["failed"]:
        raise SystemExit(f"{counts['failed']} of the campaign's runs failed: see {out / runner.RESULTS}")
    timings = pq.read_table(out / runner.TIMINGS).to_pylist()
    alone = (before + after) / 2
    rate = counts["ran"] / counts["seconds"]
    return {"workers": workers, "runs": counts["ran"], "seconds": counts["seconds"], "total": total, "rate": rate,
            "alone": alone, "before": before, "after": after, "efficiency": rate / workers * alone,
            "in_worker": sum(t["wall_s"] for t in timings) / len(timings),
            # a worker's first run loads and instantiates the FMUs (its setup: about a second); the others restart them
            "warm": _mean([t["wall_s"] for t in timings if t["setup_s"] < COLD_SETUP]),
            "cold": _mean([t["wall_s"] for t in timings if t["setup_s"] >= COLD_SETUP])}


COLD_SETUP = 0.1  # s of setup above which a run is a worker's first (FMUs loaded), not a restart (a few ms)


def _mean(values: list[float]) -> float:
    return sum(values) / len(values) if values else float("nan")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    p.add_argument("--runs", type=int, default=16, help="runs per campaign (seeds 1..N), default 16")
    p.add_argument("--stop", type=float, default=40.0, help="s per run, default 40")
    p.add_argument("--workers", type=int, nargs="+", default=[1, 2], help="worker counts, default 1 2")
    p.add_argument("--alone", type=int, default=3, help="runs timed alone before and after each campaign, default 3")
    p.add_argument("--scenarios", nargs="+", choices=("fsi", "lkf", "zse"), default=["fsi", "zse"])
    p.add_argument("--quick", action="store_true", help="6 runs of 10 s, 2 timed alone: shows the script works")
    args = p.parse_args()
    runs, stop, alone = (6, 10.0, 2) if args.quick else (args.runs, args.stop, args.alone)
    if runs < 1 or stop <= 0 or alone < 1 or min(args.workers) < 1:
        p.error("--runs, --alone and --workers must be >= 1 and --stop > 0")
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    fmus = Path("fmus")
    build_all(fmus, progress=lambda _: None)
    print(f"{machine()}\n{runs} runs of {stop:g} s per campaign (trajectory 1, mixed design, seeds 1..{runs}, no log)\n")
    with tempfile.TemporaryDirectory() as tmp:
        for scenario in args.scenarios:
            spec = spec_file(Path(tmp), scenario, stop, runs)
            for workers in args.workers:
                r = campaign(spec, Path(tmp) / f"{scenario}-w{workers}", fmus, workers, alone)
                print(f"{scenario.upper()}, {workers} worker(s): {r['runs']} runs in {r['seconds']:.2f} s = {r['rate']:.2f} runs/s, "
                      f"{r['rate'] / workers:.2f} per worker; one run alone {r['alone']:.3f} s ({r['before']:.3f} before, "
                      f"{r['after']:.3f} after) = {1 / r['alone']:.2f} runs/s; parallel efficiency {r['efficiency']:.2f}; "
                      f"a run inside a worker {r['in_worker']:.3f} s (a worker's first, loading the FMUs, {r['cold']:.3f} s; "
                      f"the others {r['warm']:.3f} s); with the cluster's start and stop {r['total']:.1f} s",
                      flush=True)
    print(f"\nload average at the end: {', '.join(f'{x:.1f}' for x in os.getloadavg())} (on {os.cpu_count()} cores)")


if __name__ == "__main__":
    main()

"""Campaign throughput on Dask: per-run set-up cost (fresh FMUs against fmi2Reset), parallel efficiency on 1 and 2
workers, the share of a campaign's time spent outside the simulations, and how long the one-line errors of a bad
scheduler address take.

The campaign: ZSE scenario, trajectory 1, both designs, 24 seeds, 40 s per run (48 runs) on a
LocalCluster of 1, then 2 worker processes (one thread each). Rates count from the first submission
to the last result; the cluster's start is printed apart. Parallel efficiency = (runs per second) /
(workers / the wall time of one run alone): 1.0 when N workers run N times as many runs per second
as one run alone allows. The wall time of one run alone is the mean over the same cases run one after
the other in this process (warm: the FMUs instantiated once, reset between runs), the mean of its measures right
before and right after the campaign.
Targets: efficiency >= 0.9 on 1 worker, >= 0.85 on 2 on an idle 2-core machine; time outside the simulations <= 5 %.
The machine's load is printed: the figures mean little on a machine other work is using.
Run: python benchmarks/campaign.py [--runs 48] [--stop-time 40] [--skip-errors]
"""

from __future__ import annotations

import argparse
import os
import platform
import socket
import subprocess
import sys
import tempfile
import time
from dataclasses import asdict
from pathlib import Path

import pyarrow.parquet as pq
from tiltload.master.app.campaign import runner as campaign
from tiltload.master.app.campaign.run_case import run_case
from tiltload.master.app.campaign.spec import load
from tiltload.master.app.loop.fmus import build_all
from tiltload.master.app.loop.thesis import default_system
from tiltload.master.engine.execution import Execution

SPEC = """
name = "scaling"
[base]
scenario = "zse"
trajectory = 1
controllers = ["dlqr", "mixed"]
stop_time = {stop}
[vary]
seeds = [{seeds}]
"""


def machine() -> str:
    cpu = next((line.split(":", 1)[1].strip() for line in Path("/proc/cpuinfo").read_text().splitlines()
                if line.startswith("model name")), platform.processor()) if Path("/proc/cpuinfo").exists() else platform.processor()
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    return f"{platform.node()}: {os.cpu_count()} cores ({cpu}), Python {platform.python_version()}, load average {load}"


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


def single_run_wall(spec: Path, fmus: Path, n: int) -> float:
    """The mean wall time of one run alone: n of the campaign's cases one after the other here (after one warm-up)."""
    c = load(spec)
    cases = c.cases[:n + 1]
    run_case(c.base(), asdict(cases[0]), str(fmus.resolve()), None)
    t0 = time.perf_counter()
    for case in cases[1:]:
        run_case(c.base(), asdict(case), str(fmus.resolve()), None)
    return (time.perf_counter() - t0) / (len(cases) - 1)


def efficiency(spec: Path, fmus: Path, tmp: Path, alone_runs: int) -> None:
    rates = {}
    for workers in (1, 2):
        before = single_run_wall(spec, fmus, alone_runs)  # before and after: a shared machine's load drifts
        out = tmp / f"w{workers}"
        t0 = time.perf_counter()
        _, counts = campaign.run(spec, out, fmus=fmus, progress=lambda _: None, workers=workers)
        total = time.perf_counter() - t0
        after = single_run_wall(spec, fmus, alone_runs)
        alone = (before + after) / 2
        wall = counts["seconds"]
        busy = sum(t["wall_s"] for t in pq.read_table(out / campaign.TIMINGS).to_pylist())
        rates[workers] = counts["ran"] / wall
        print(f"{workers} worker(s): {counts['ran']} runs in {wall:.1f} s = {rates[workers]:.2f} runs/s; one run alone "
              f"{alone:.3f} s ({before:.3f} before, {after:.3f} after); parallel efficiency "
              f"{rates[workers] * alone / workers:.2f}; time outside the simulations {100 * (1 - busy / (wall * workers)):.1f} %; "
              f"with the cluster's start and stop {total:.1f} s")
    print(f"scaling 1 -> 2 workers: {rates[2] / rates[1]:.2f}x")


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _tiltload(*args: str) -> tuple[float, subprocess.CompletedProcess]:
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", "from tiltload.master.app.cli import entry; entry()", *args],
                          capture_output=True, text=True)
    return time.perf_counter() - start, done


def error_times(spec: Path, tmp: Path) -> None:
    """Seconds from `tiltload campaign` to its one-line error (exit 2), as a user meets them (a fresh process each)."""
    silent = socket.socket()  # listens, never answers: a port that is not a Dask scheduler's
    silent.bind(("127.0.0.1", 0))
    silent.listen(8)
    lonely = f"tcp://127.0.0.1:{_free_port()}"  # a scheduler without workers
    scheduler = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port",
                                  lonely.rsplit(":", 1)[1], "--no-dashboard"], stdout=subprocess.DEVNULL,
                                 stderr=subprocess.DEVNULL)
    cases = [("garbage", []), (f"tcp://127.0.0.1:{_free_port()}", []), ("http://127.0.0.1:8787", []),
             (f"tcp://127.0.0.1:{silent.getsockname()[1]}", ["--connect-timeout", "2"]), (lonely, ["--worker-timeout", "2"])]
    seconds, _ = _tiltload("--help")
    print(f"\n`tiltload --help` (the command's own start, the floor of every figure below): {seconds:.2f} s")
    time.sleep(3)  # the scheduler is up
    try:
        for address, extra in cases:
            seconds, done = _tiltload("campaign", str(spec), "--out", str(tmp / "bad"), "--fmus", str(tmp / "no-fmus"),
                                      "--scheduler", address, *extra)
            print(f"--scheduler {address} {' '.join(extra)}: exit {done.returncode}, {seconds:.2f} s, "
                  f"{len(done.stderr.splitlines())} line: {done.stderr.strip()[:100]}...")
    finally:
        scheduler.terminate()
        scheduler.wait()
        silent.close()


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    p.add_argument("--runs", type=int, default=48, help="campaign size (even: both designs), default 48")
    p.add_argument("--stop-time", type=float, default=40.0, help="s per run, default 40")
    p.add_argument("--skip-errors", action="store_true", help="no timing of the one-line errors")
    args = p.parse_args()
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    fmus = Path("fmus")
    build_all(fmus)
    print(machine())
    fresh, reset = setup_costs(fmus)
    print(f"per-run set-up of the four FMUs: instantiate {fresh * 1e3:.1f} ms, fmi2Reset + initialize {reset * 1e3:.2f} ms\n")
    with tempfile.TemporaryDirectory() as folder:
        tmp = Path(folder)
        spec = tmp / "scaling.toml"
        spec.write_text(SPEC.format(stop=args.stop_time, seeds=", ".join(str(s) for s in range(1, args.runs // 2 + 1))))
        efficiency(spec, fmus, tmp, alone_runs=min(8, args.runs - 1))
        if not args.skip_errors:
            error_times(spec, tmp)
    print(f"\n{machine()} (after)")


if __name__ == "__main__":
    main()

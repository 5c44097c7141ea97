"""A campaign of N short runs and a falsification with a budget of N, each run as a user runs it (`tiltload campaign` /
`tiltload falsify` on a local cluster), in a process of its own: its wall time, the client's peak resident memory
(VmHWM of /proc/self/status: the process that dispatches, stores and assembles, with the local cluster's scheduler
in it; not the workers) and the files it wrote. Run at two sizes, the peak shows whether the client grows with N:
the peak when the report begins (the runs dispatched and stored, the results assembled) and at the end (the report's
HTML page lists at most 500 runs, the failing first, and counts them all: it no longer grows with N).

The campaign: 2 s runs of the zse loop, varying the controller (dlqr, mixed), the load's mass (5 values) and the seed
(N / 10 seeds, with gusts). The search: uniform, batches of 200, over a gust's amplitude and heading in 2 s runs of the
fsi loop, a requirement no point falsifies (so the whole budget is spent).

Run: python benchmarks/scale_20k.py [--runs 2000 20000] [--only campaign|falsify] [--workers 2] [--write]   (minutes at
20,000; --write: into docs/timings.json, the figures of docs/timings.md's "Scale", with the date, machine and load)
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

CAMPAIGN = """
name = "scale"
[base]
scenario = "zse"
trajectory = 1
controllers = ["dlqr", "mixed"]
stop_time = 2.0
gusts = true
[vary]
seeds = {seeds}
[[vary.parameters]]
name = "load_mass"
targets = ["plant.m_L"]
values = [0.05, 0.1, 0.15, 0.2, 0.25]
"""

FALSIFY = """
name = "scale"
optimizer = "uniform"
batch = 200
[base]
scenario = "fsi"
trajectory = 1
stop_time = 2.0
gusts = false
[[requirements]]
name = "swing"
formula = "always[0.5:1.9] (abs(plant.gamma_1) < 3.0)"
[[search]]
name = "amp"
target = "gust.amplitude"
range = [0.0, 5.0]
[[search]]
name = "heading"
target = "gust.direction"
range = [0.0, 360.0]
[gust]
start = 0.5
duration = 0.8
[budget]
simulations = {runs}
"""

# the child: the CLI's main in this process, then its own peak memory and wall time, as one JSON line; also the peak
# and the time when the report began (the runs stored and the results assembled: the report's pages list every run)
CHILD = """
import json, sys, time
def peak():
    status = dict(line.split(":", 1) for line in open("/proc/self/status") if ":" in line)
    return int(status["VmHWM"].split()[0]) / 1024
started = time.perf_counter()
marks = {}
import tiltload.master.app.campaign.report as campaign_report
import tiltload.master.app.falsify.report as falsify_report
def marked(module, name):
    original = getattr(module, name)
    def first(*args, **kwargs):
        marks.setdefault("before_report_mb", peak())
        marks.setdefault("before_report_s", time.perf_counter() - started)
        return original(*args, **kwargs)
    setattr(module, name, first)
marked(campaign_report, "report")
marked(falsify_report, "write")
from tiltload.master.app.cli import main
code = main(sys.argv[1:])
wall = time.perf_counter() - started
print(json.dumps({"exit": code, "wall_s": wall, "peak_rss_mb": peak(), **marks}))
"""


def files(folder: Path) -> tuple[int, int]:
    """(files written under folder, of them parts)."""
    every = [p for p in folder.rglob("*") if p.is_file()]
    return len(every), sum(1 for p in every if p.parent.name == "parts")


def rows(path: Path) -> int:
    import pyarrow.parquet as pq

    return pq.ParquetFile(path).metadata.num_rows


def measure(kind: str, runs: int, workers: int, fmus: Path, folder: Path) -> dict:
    spec = folder / f"{kind}-{runs}.toml"
    out = folder / f"{kind}-{runs}"
    if kind == "campaign":
        assert runs % 10 == 0, "the campaign's runs: 2 controllers x 5 masses x seeds"
        spec.write_text(CAMPAIGN.format(seeds=list(range(1, runs // 10 + 1))))
        args = ["campaign", str(spec), "--out", str(out), "--fmus", str(fmus), "--workers", str(workers)]
        results = out / "results.parquet"
    else:
        spec.write_text(FALSIFY.format(runs=runs))
        args = ["falsify", str(spec), "--out", str(out), "--fmus", str(fmus), "--workers", str(workers)]
        results = out / "falsification.parquet"
    load = os.getloadavg()[0]
    proc = subprocess.run([sys.executable, "-c", CHILD, *args], capture_output=True, text=True,
                          env={**os.environ, "OPENBLAS_NUM_THREADS": "1"})
    if proc.returncode != 0 or not proc.stdout.strip():
        raise SystemExit(f"{kind} {runs}: exit {proc.returncode}: {proc.stderr[-2000:]}")
    got = json.loads(proc.stdout.strip().splitlines()[-1])
    if got["exit"] != 0:
        raise SystemExit(f"{kind} {runs}: tiltload exit {got['exit']}: {proc.stderr[-2000:]}")
    written, parts = files(out)
    return {"kind": kind, "runs": runs, **got, "rows": rows(results), "files": written, "parts": parts,
            "load_before": load, "load_after": os.getloadavg()[0]}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    parser.add_argument("--runs", type=int, nargs="+", default=[2000, 20000])
    parser.add_argument("--only", choices=("campaign", "falsify"))
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--fmus", type=Path, default=ROOT / "fmus")
    parser.add_argument("--keep", type=Path, help="write into this folder (kept) rather than a temporary one")
    parser.add_argument("--write", action="store_true", help="store in docs/timings.json and regenerate docs/timings.md")
    args = parser.parse_args()
    from tiltload.master.app.loop.fmus import build_all

    build_all(args.fmus, progress=lambda *_: None)
    print(f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, {os.cpu_count()} cores, {args.workers} workers, "
          f"load average {os.getloadavg()[0]:.1f}", flush=True)
    print(f"{'what':>9} {'runs':>6} {'wall s':>8} {'runs/s':>7} {'peak RSS MB':>12} {'before report':>14} {'rows':>6} "
          f"{'files':>6} {'parts':>6} {'load':>9}", flush=True)
    with tempfile.TemporaryDirectory(prefix="tiltload-scale-") as tmp:
        folder = args.keep or Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        for kind in (args.only,) if args.only else ("campaign", "falsify"):
            for runs in args.runs:
                m = measure(kind, runs, args.workers, args.fmus.resolve(), folder)
                print(f"{kind:>9} {runs:>6} {m['wall_s']:>8.1f} {runs / m['wall_s']:>7.1f} {m['peak_rss_mb']:>12.0f} "
                      f"{m.get('before_report_mb', 0):>14.0f} {m['rows']:>6} {m['files']:>6} {m['parts']:>6} "
                      f"{m['load_before']:>4.1f}-{m['load_after']:<4.1f}",
                      flush=True)
                print("  " + json.dumps(m), flush=True)
                if args.write:
                    store(m)
    return 0


def store(measured: dict) -> None:
    """Into docs/timings.json's scale figures (replacing the same kind and size), and docs/timings.md again."""
    import datetime

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import user_timings

    data = json.loads(user_timings.TIMINGS.read_text()) if user_timings.TIMINGS.exists() else {}
    measured = {**measured, "machine": user_timings.machine(), "date": datetime.date.today().isoformat()}
    kept = [m for m in data.get("scale", []) if (m["kind"], m["runs"]) != (measured["kind"], measured["runs"])]
    data["scale"] = sorted([*kept, measured], key=lambda m: (m["kind"], m["runs"]))
    user_timings.TIMINGS.write_text(json.dumps(data, indent=1) + "\n")
    user_timings.PAGE.write_text(user_timings.render(data))


if __name__ == "__main__":
    sys.exit(main())

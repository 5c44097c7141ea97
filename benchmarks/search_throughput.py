"""Searches and campaigns against the machine's limit (issue 52), this tree side by side with another (f642aa0) in one
run: CPU per evaluation per kind of dimension against the loop's own cost, and evaluations per second against the
limit (workers / the loop's own cost per run) on 1 and 2 workers, for the four shipped falsification specs and a
campaign of short runs.

    python benchmarks/search_throughput.py                         # this tree and /work/wt/base (about 3 minutes quiet)
    python benchmarks/search_throughput.py --before none           # this tree only
    python benchmarks/search_throughput.py --evaluations 40 --runs 400

What each figure is:
- cpu ms: the worker processes' own CPU time over the measurement (every worker's, Dask's share in them included)
  divided by the evaluations; `thread ms` the median of the rows' cpu_s (the evaluation's own thread: the run, its
  feasibility check, its robustness). Meaningful under load.
- loop ms: the loop's own cost of the same run, measured in this process with this tree's engine on this tree's FMUs:
  run_plan of the kind's middle point with no log and no observer on a warm execution (restart included), the median
  of 15 (engine/lifecycle.py).
- evals/s: evaluations over the search's (or campaign's) own seconds (no cluster start); limit: workers / loop s;
  fraction = evals/s / limit. Wall figures mean nothing on a loaded machine: the load average is printed beside each.

Each tree runs in a process of its own (`--inner`), with its own interpreter, FMU folder and FMU cache (TILTLOAD_CACHE),
the searches with `--optimizer uniform` and branching off, each running its whole budget (past a falsification too, where
the tree can: f642aa0 stops at it, and its figures then count the evaluations stored).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from inspect import signature
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = ("swing_gust", "altitude_thrust_loss", "tracking_wind_load", "zse_containment")
LOOP = """scenario = "fsi"
trajectory = {trajectory}
controller = "mixed"
stop_time = 8.1
gusts = false
"""
REQUIREMENT = """[[requirements]]
name = "swing"
formula = "always[2:8] (abs(plant.gamma_1) < 0.445)"
"""
# one kind of dimension each (the shipped specs cover gusts, faults, FMU parameters with steady wind, and the ZSE's)
KINDS = {
    "steady wind": ("1", [("wind_x", "scenario.steady_wind_x", -5.0, 5.0), ("wind_y", "scenario.steady_wind_y", -5.0, 5.0)]),
    "plant parameters": ("1", [("load_mass", "plant.m_L", 0.04, 0.08), ("rod_length", "plant.l", 0.45, 0.6)]),
    "initial offsets": ("1", [("x0", "initial.x", -0.2, 0.2), ("y0", "initial.y", -0.2, 0.2)]),
    "waypoints": (None, [("wp1_z", "waypoints.1.z", -0.5, 0.5), ("wp1_t", "waypoints.1.t", -0.5, 0.5)]),
}
CAMPAIGN = """name = "short_runs"
[base]
scenario = "fsi"
trajectory = 1
controllers = ["dlqr", "mixed"]
stop_time = 2.0
gusts = false
[vary]
seeds = {seeds}
method = "grid"
[[vary.parameters]]
name = "load_mass"
targets = ["plant.m_L"]
values = [0.05, 0.06]
[keep]
metrics = ["ISE", "IADU", "max_tracking_error"]
logs = false
"""


def load() -> str:
    return f"load {os.getloadavg()[0]:.1f}"


def kind_specs(folder: Path) -> dict[str, Path]:
    """The specs measured: the shipped ones, and one a kind of dimension they do not isolate."""
    out = {name: ROOT / "docs" / "falsification" / f"{name}.toml" for name in SHIPPED}
    mission = ROOT / "docs" / "examples" / "mission.csv"
    for kind, (trajectory, dims) in KINDS.items():
        text = f'name = "{kind.replace(" ", "_")}"\noptimizer = "uniform"\nseed = 0\n[base]\n'
        text += LOOP.format(trajectory=trajectory if trajectory else json.dumps(str(mission)))
        text += REQUIREMENT
        for name, target, lo, hi in dims:
            text += f'[[search]]\nname = "{name}"\ntarget = "{target}"\nrange = [{lo}, {hi}]\n'
        text += "[budget]\nsimulations = 500\n"
        path = folder / f"{kind.replace(' ', '_')}.toml"
        path.write_text(text)
        out[kind] = path
    return out


def worker_cpu(client) -> float:
    return sum(client.run(time.process_time).values())


def inner(fmus: Path, evaluations: int, runs: int, kinds: bool) -> None:
    """In this tree's interpreter: the searches and the campaign on 1 and 2 workers; JSON lines on stdout."""
    import pyarrow.parquet as pq
    from tiltload.master.app.batch.cluster import local_cluster
    from tiltload.master.app.campaign.runner import run as campaign
    from tiltload.master.app.falsify.runner import falsify

    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    with tempfile.TemporaryDirectory(prefix="search-throughput-") as tmp:
        tmp = Path(tmp)
        specs = kind_specs(tmp)
        for workers in (1, 2):
            client, cluster = local_cluster(workers, scratch=tmp)
            try:
                names = list(specs) if (kinds and workers == 1) else list(SHIPPED)
                for name in names:
                    out = tmp / f"{name}-{workers}"
                    falsify(specs[name], out, fmus, optimizer="uniform", seed=1, simulations=4 * workers, client=client,
                            progress=lambda _: None, write_report=False, branch="off")  # warm: the workers' executions
                    out2 = tmp / f"{name}-{workers}-measured"
                    before, la = worker_cpu(client), os.getloadavg()[0]
                    whole = {"stop_when_falsified": False} if "stop_when_falsified" in signature(falsify).parameters else {}
                    _, outcome, _ = falsify(specs[name], out2, fmus, optimizer="uniform", seed=2, simulations=evaluations,
                                            client=client, progress=lambda _: None, write_report=False, branch="off",
                                            **whole)
                    cpu = worker_cpu(client) - before
                    rows = pq.read_table(out2 / "falsification.parquet").to_pylist()
                    print(json.dumps({"what": name, "workers": workers, "evaluations": len(rows), "seconds": outcome.seconds,
                                      "cpu_ms": 1e3 * cpu / len(rows),
                                      "thread_ms": 1e3 * statistics.median(r["cpu_s"] for r in rows),
                                      "refused": sum(1 for r in rows if str(r.get("error", "")).startswith("the reference")),
                                      "load": la}), flush=True)
                seeds = list(range(1, runs // 4 + 1))
                spec = tmp / "short_runs.toml"
                spec.write_text(CAMPAIGN.format(seeds=seeds))
                before, la = worker_cpu(client), os.getloadavg()[0]  # the searches warmed the workers' executions
                _, counts = campaign(spec, tmp / f"campaign-{workers}", fmus, progress=lambda _: None,
                                     scheduler=cluster.scheduler_address, workers=workers)
                cpu = worker_cpu(client) - before
                print(json.dumps({"what": "campaign", "workers": workers, "evaluations": counts["ran"],
                                  "seconds": counts["seconds"], "cpu_ms": 1e3 * cpu / max(counts["ran"], 1),
                                  "thread_ms": float("nan"), "refused": 0, "load": la}), flush=True)
            finally:
                client.close()
                cluster.close()


def loop_costs(fmus: Path) -> dict[str, float]:
    """The loop's own cost (s) of each kind's middle point and of a short campaign run, this tree's engine."""
    from dataclasses import replace

    import numpy as np
    from tiltload.master.app.case.system import case_system
    from tiltload.master.app.falsify.runner import make_case
    from tiltload.master.app.falsify.space import case_flight, values_at
    from tiltload.master.app.falsify.spec import load as load_spec
    from tiltload.master.app.loop.fmus import is_foreign
    from tiltload.master.engine.lifecycle import ExecutionPool, RunPlan, run_plan

    def median_cost(system, stop) -> float:
        pool = ExecutionPool()
        run_plan(RunPlan(system, stop, isolate=is_foreign), pool)
        times = []
        for _ in range(15):
            started = time.thread_time()
            run_plan(RunPlan(system, stop, isolate=is_foreign), pool)
            times.append(time.thread_time() - started)
        pool.close()
        return statistics.median(times)

    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name, path in kind_specs(Path(tmp)).items():
            spec = load_spec(path)
            base = spec.base()
            case = make_case(base)("mid", values_at(spec.dimensions, np.full(len(spec.dimensions), 0.5)))
            run_base, parameters = case_flight(base, case["parameters"])
            out[name] = median_cost(case_system(fmus, run_base, base.controller, base.seed, parameters), base.stop_time)
        spec = load_spec(ROOT / "docs" / "falsification" / "swing_gust.toml")  # the campaign's run: FSI, 2 s, each design
        costs = [median_cost(case_system(fmus, replace(spec.base(), stop_time=2.0), c, 1, {"plant.m_L": 0.05}), 2.0)
                 for c in ("dlqr", "mixed")]
        out["campaign"] = statistics.mean(costs)
    return out


def run_tree(python: str, fmus: Path, env: dict, evaluations: int, runs: int, cwd: Path, kinds: bool) -> list[dict]:
    args = [python, str(Path(__file__).resolve()), "--inner", "--fmus", str(fmus), "--evaluations", str(evaluations),
            "--runs", str(runs)] + ([] if kinds else ["--no-kinds"])
    done = subprocess.run(args, env={**os.environ, **env}, cwd=cwd, capture_output=True, text=True)
    if done.returncode:
        sys.stderr.write(done.stderr[-3000:])
        raise SystemExit(f"{python} failed ({done.returncode})")
    return [json.loads(line) for line in done.stdout.splitlines() if line.startswith("{")]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter, allow_abbrev=False)
    ap.add_argument("--inner", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--no-kinds", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--fmus", type=Path, default=ROOT / "fmus")
    ap.add_argument("--evaluations", type=int, default=200, help="evaluations a search measures (after 4 a worker to warm up)")
    ap.add_argument("--runs", type=int, default=2000, help="runs of the short-run campaign (a multiple of 4)")
    ap.add_argument("--before", default="/work/wt/base", help="the other tree ('none': this one only)")
    ap.add_argument("--before-python", default="/work/venvs/base/bin/python")
    ap.add_argument("--before-cache", default="/work/cache-base", help="its TILTLOAD_CACHE")
    a = ap.parse_args()
    if a.inner:
        inner(a.fmus.resolve(), a.evaluations, a.runs, not a.no_kinds)
        return
    from tiltload.master.app.loop.fmus import build_all

    started = time.perf_counter()
    build_all(a.fmus.resolve(), progress=lambda _: None)
    print(f"the loop's own cost ({load()}) ...", flush=True)
    loop = loop_costs(a.fmus.resolve())
    trees = {"after": run_tree(sys.executable, a.fmus.resolve(), {}, a.evaluations, a.runs, ROOT, True)}
    if a.before != "none":
        before = Path(a.before)
        trees["before"] = run_tree(a.before_python, before / "fmus", {"TILTLOAD_CACHE": a.before_cache}, a.evaluations,
                                   a.runs, before, True)
    print(f"\nCPU per evaluation, 1 worker, against the loop's own cost (this tree's engine and FMUs, {load()} now)")
    print(f"| what | loop ms | {' | '.join(f'{t} cpu ms | {t} thread ms | {t} ratio | {t} load' for t in trees)} |")
    print("|---|---|" + "---|---|---|---|" * len(trees))
    for what, cost in loop.items():
        cells = []
        for rows in trees.values():
            r = next((r for r in rows if r["what"] == what and r["workers"] == 1), None)
            cells.append("n/a | n/a | n/a | n/a" if r is None else
                         f"{r['cpu_ms']:.2f} | {r['thread_ms']:.2f} | {r['cpu_ms'] / (1e3 * cost):.2f} | {r['load']:.1f}")
        print(f"| {what} | {1e3 * cost:.2f} | {' | '.join(cells)} |")
    print("\nThroughput against the limit (workers / the loop's own cost per run)")
    print(f"| what | workers | limit /s | {' | '.join(f'{t} evals/s | {t} fraction | {t} load' for t in trees)} |")
    print("|---|---|---|" + "---|---|---|" * len(trees))
    for what in (*SHIPPED, "campaign"):
        for workers in (1, 2):
            limit = workers / loop[what]
            cells = []
            for rows in trees.values():
                r = next((r for r in rows if r["what"] == what and r["workers"] == workers), None)
                rate = r["evaluations"] / r["seconds"] if r else float("nan")
                cells.append("n/a | n/a | n/a" if r is None else f"{rate:.1f} | {rate / limit:.2f} | {r['load']:.1f}")
            print(f"| {what} | {workers} | {limit:.0f} | {' | '.join(cells)} |")
    print(f"\n{time.perf_counter() - started:.0f} s in all ({load()} at the end)")


if __name__ == "__main__":
    main()

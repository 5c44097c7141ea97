"""Falsification side by side: FR (falsified runs out of the seeds) and mean / median simulations to falsify, for uniform
random, CMA-ES, TPE and PSY-TaLiRo (its uniform random and dual annealing, driven through its Python API), on the
requirements of docs/falsification/*.toml; a guaranteed property (the ZSE containing the true state) searched with a
large budget; the cost of one evaluation with the observer against a log read back; simulations per second.

    python benchmarks/falsification.py [--seeds 10] [--budget 200] [--workers 2] [--guaranteed 500]
    python benchmarks/falsification.py --only tracking_wind_load --tools dual_annealing   # one row
    python benchmarks/falsification.py --calibrate 300     # the distribution of each requirement's signal margin
    python benchmarks/falsification.py --throughput 320    # simulations/s with and without early stop and branching

PSY-TaLiRo runs in its own interpreter (/work/venvs/oracles: psy-taliro pins what ours does not): a driver script there
builds its optimizer and a cost function that writes each sample to its stdout as a JSON line and reads the cost from
its stdin; this process answers each line with our evaluation of that point on the same cluster (the bridge). The
simulations it needs are counted on our side: the index of its first sample with robustness < 0.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import subprocess
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SPECS = ROOT / "docs" / "falsification"
NEEDLES = ("swing_gust", "altitude_thrust_loss", "tracking_wind_load")
TOOLS = ("uniform", "cmaes", "tpe", "neldermead", "uniform_random", "dual_annealing")  # ours, then PSY-TaLiRo's
ORACLE_PYTHON = Path(os.environ.get("TILTLOAD_ORACLES_PYTHON", "/work/venvs/oracles/bin/python"))

PSY_DRIVER = r"""
import json, sys
from staliro import TestOptions, costfunc, staliro
from staliro.optimizers import DualAnnealing, UniformRandom

kind, seed, budget, dims = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])

@costfunc
def cost(inputs):
    x = [float(inputs.static[f"u{i}"]) for i in range(dims)]
    sys.stdout.write(json.dumps({"x": x}) + "\n")
    sys.stdout.flush()
    return float(json.loads(sys.stdin.readline())["rho"])

optimizer = DualAnnealing(min_cost=0.0) if kind == "dual_annealing" else UniformRandom(min_cost=0.0)
options = TestOptions(static_inputs={f"u{i}": (0.0, 1.0) for i in range(dims)}, iterations=budget, runs=1, seed=seed)
staliro(cost, optimizer, options)
sys.stdout.write(json.dumps({"done": True}) + "\n")
sys.stdout.flush()
"""


def load_spec(name: str, tmp: Path, threshold: float | None = None):
    from tiltload.master.app.falsify.spec import load

    text = (SPECS / f"{name}.toml").read_text()
    if threshold is not None:  # calibration: a bound nothing reaches, so the robustness is the margin to it
        import re

        text = re.sub(r"< [0-9.]+\)", f"< {threshold})", text)
    path = tmp / f"{name}.toml"
    path.write_text(text)
    return load(path)


def run_search(spec, client, fmus, optimizer, seed, budget, stop=True):
    from tiltload.master.app.falsify.runner import cluster_batch, identity, make_case
    from tiltload.master.app.falsify.search import search

    base = spec.base()
    ident = identity(spec) + f"-{optimizer}-{seed}"
    return search(spec.dimensions, optimizer, seed, cluster_batch(client, "the local cluster", base, fmus), make_case(base),
                  budget, None, None, ident, spec.batch, stop_when_falsified=stop)


def psy_taliro(spec, client, fmus, kind, seed, budget) -> tuple[int | None, list[float]]:
    """PSY-TaLiRo's optimizer in its interpreter, each sample evaluated here: (first falsifying index, robustness list)."""
    from tiltload.master.app.falsify.evaluate import evaluate
    from tiltload.master.app.falsify.runner import make_case
    from tiltload.master.app.falsify.space import values_at

    base = spec.base()
    make = make_case(base)
    # its TestOptions refuse a seed of 0: seed + 1
    proc = subprocess.Popen([str(ORACLE_PYTHON), "-c", PSY_DRIVER, kind, str(seed + 1), str(budget), str(len(spec.dimensions))],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    values, first = [], None
    try:
        for line in proc.stdout:
            msg = json.loads(line)
            if msg.get("done"):
                break
            unit = np.clip(np.array(msg["x"]), 0.0, 1.0)
            case = make(f"psy-{kind}-{seed}-{len(values)}", values_at(spec.dimensions, unit))
            row = client.submit(evaluate, base, case, str(fmus), pure=False).result()["row"]
            rho = row["robustness"]
            rho = 1e6 if rho is None or math.isnan(rho) else float(np.clip(rho, -1e6, 1e6))
            values.append(rho)
            if first is None and rho < 0:
                first = len(values) - 1
            proc.stdin.write(json.dumps({"rho": rho}) + "\n")
            proc.stdin.flush()
            if len(values) >= budget:  # its own budget counts the same; never more than ours
                break
    finally:
        proc.kill()
        proc.wait()
    return first, values


def row_of(label: str, firsts: list[int | None], budget: int, seconds: float) -> dict:
    hits = [f + 1 for f in firsts if f is not None]
    return {"tool": label, "FR": f"{len(hits)}/{len(firsts)}",
            "mean": statistics.mean(hits) if hits else math.nan, "median": statistics.median(hits) if hits else math.nan,
            "wall_s": seconds}


def table(rows: list[dict], uniform_mean: float) -> str:
    lines = ["| tool | FR | mean sims | median sims | uniform mean / mean | wall (s) |", "|---|---|---|---|---|---|"]
    for r in rows:
        ratio = uniform_mean / r["mean"] if r["mean"] == r["mean"] and uniform_mean == uniform_mean else math.nan
        lines.append(f"| {r['tool']} | {r['FR']} | {r['mean']:.1f} | {r['median']:.1f} | {ratio:.2f} | {r['wall_s']:.0f} |")
    return "\n".join(lines)


def calibrate(client, fmus, tmp, n, names):
    """Each needle's margin (1000 - robustness: the worst |signal| over its window) over n uniform points."""
    for name in names:
        spec = load_spec(name, tmp, 1000.0)
        out = run_search(spec, client, fmus, "uniform", 12345, n, stop=False)
        worst = np.array([1000.0 - r["robustness"] for r in out.rows if r["robustness"] == r["robustness"]])
        q = np.percentile(worst, [50, 90, 95, 98, 99, 99.5])
        print(f"{name}: {len(worst)} runs; worst |signal| percentiles 50/90/95/98/99/99.5: "
              + " ".join(f"{v:.4g}" for v in q) + f"; max {worst.max():.4g}; nominal-free share failing at each: "
              + "; ".join(f"{v:.4g}: {np.mean(worst > v):.3f}" for v in q[2:]))


def evaluation_cost(client, fmus, tmp, repeat: int) -> str:
    """One evaluation's wall time in a worker: the observer against the full log written and read back (same case)."""
    from tiltload.master.app.falsify.space import case_parameters, values_at

    spec = load_spec(NEEDLES[0], tmp)
    base = spec.base()
    values = values_at(spec.dimensions, np.full(len(spec.dimensions), 0.5))
    case = {"run_id": "cost", "values": values, "parameters": case_parameters(base, values)}
    res = client.submit(_cost_in_worker, base, case, str(fmus), str(tmp), repeat, pure=False).result()
    return (f"one evaluation (8.1 s FSI run, best of {repeat}, in a worker): observer {res['observer'] * 1e3:.1f} ms, "
            f"full MCAP log + read back {res['log'] * 1e3:.1f} ms (x{res['log'] / res['observer']:.2f}); "
            f"robustness equal: {res['same']}")


def _cost_in_worker(base, case, fmus, tmp, repeat):
    from tiltload.master.app.falsify.evaluate import evaluate, robustness, run_loop
    from tiltload.master.app.falsify.signals import trace_from_log
    from tiltload.master.engine.log.logger import McapLogger

    best_obs = best_log = math.inf
    for k in range(repeat):
        t = time.perf_counter()
        row = evaluate(base, case, fmus)["row"]
        best_obs = min(best_obs, time.perf_counter() - t)
        t = time.perf_counter()
        log = Path(tmp) / f"cost{k}.mcap"
        run_loop(base, case["parameters"], Path(fmus), [McapLogger(log)])
        rho, _ = robustness(base.requirements, trace_from_log(log, base.signals, 0.012), True)
        best_log = min(best_log, time.perf_counter() - t)
        log.unlink()
    return {"observer": best_obs, "log": best_log, "same": min(rho) == row["robustness"]}




def throughput(client, fmus, tmp, n: int, names, rounds: int = 4) -> None:
    """Simulations per second of uniform random searches (n evaluations each, not stopped at a falsification) on the
    cluster, with and without early stop and branching from a snapshot, the configurations alternated round by round
    (a load that changes falls on each); once at the requirement's bound, once at half of it (many runs fail)."""
    import re

    from tiltload.master.app.falsify.branching import branch_tick, with_branch
    from tiltload.master.app.falsify.runner import cluster_batch, make_case
    from tiltload.master.app.falsify.search import search
    from tiltload.master.app.loop.thesis import TICK

    print(f"\n## throughput: uniform random, {n} evaluations a configuration in {rounds} rounds, batches of 8, "
          f"{len(client.scheduler_info()['workers'])} workers")
    print("| requirement | bound | early stop | branch | simulations/s | CPU ms an evaluation | runs stopped early | "
          "mean simulated s |")
    print("|---|---|---|---|---|---|---|---|")
    for name in names:
        bound = float(re.search(r"< ([0-9.]+)\)", (SPECS / f"{name}.toml").read_text()).group(1))
        for label, threshold in (("as shipped", None), ("halved", bound / 2)):
            spec = load_spec(name, tmp, threshold)
            base0 = spec.base()
            ticks = branch_tick(spec.dimensions, base0["faults"], TICK)
            configs = [(e, b) for e in (False, True) for b in ((False, True) if ticks else (False,))]
            got = {c: {"sims": 0, "s": 0.0, "stopped": 0, "simulated": 0.0, "cpu": 0.0} for c in configs}
            for r in range(-1, rounds):  # round -1: a warm-up (the workers' executions and snapshots made), not counted
                for early, branch in configs:
                    base = replace(base0, early_stop=early)
                    if branch:
                        base = with_branch(base, ticks)
                    started = time.perf_counter()
                    out = search(spec.dimensions, "uniform", r + 1, cluster_batch(client, "the local cluster", base, fmus),
                                 make_case(base), n // rounds if r >= 0 else 16, None, None,
                                 f"throughput-{name}-{label}-{early}-{branch}-{r}", 8, stop_when_falsified=False)
                    if r < 0:
                        continue
                    g = got[(early, branch)]
                    g["s"] += time.perf_counter() - started
                    g["sims"] += out.simulations
                    g["stopped"] += sum(1 for row in out.rows if row.get("stopped_at") == row.get("stopped_at")
                                        and row.get("stopped_at") is not None)
                    g["simulated"] += sum(row["sim_time"] for row in out.rows)
                    g["cpu"] += sum(row["cpu_s"] for row in out.rows)
            for (early, branch), g in got.items():
                print(f"| {name} | {label} ({threshold or bound:g}) | {'on' if early else 'off'} | "
                      f"{'on' if branch else ('off' if ticks else 'n/a')} | {g['sims'] / g['s']:.1f} | {g['cpu'] / g['sims'] * 1e3:.2f} | "
                      f"{g['stopped']}/{g['sims']} | {g['simulated'] / g['sims']:.2f} |", flush=True)
    print(f"load average after: {os.getloadavg()[0]:.1f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--budget", type=int, default=200)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--guaranteed", type=int, default=500, help="budget of the guaranteed property's search (0: skip)")
    ap.add_argument("--calibrate", type=int, default=0, help="only: the needles' margins over N uniform points")
    ap.add_argument("--throughput", type=int, default=0,
                    help="only: simulations/s with and without early stop and branching (N evaluations a configuration)")
    ap.add_argument("--only", default=None, help="one requirement of docs/falsification")
    ap.add_argument("--no-psy", action="store_true", help="skip PSY-TaLiRo")
    ap.add_argument("--tools", default=",".join(TOOLS), help=f"a comma-separated subset of {', '.join(TOOLS)}")
    ap.add_argument("--no-cost", action="store_true", help="skip the one-evaluation cost (observer against log)")
    ap.add_argument("--figure", type=Path, default=ROOT / "docs" / "figures" / "falsification_best_robustness.png")
    args = ap.parse_args()
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    from tiltload.master.app.batch.cluster import local_cluster
    from tiltload.master.app.falsify.report import figure
    from tiltload.master.app.loop.fmus import build_all

    fmus = (ROOT / "fmus").resolve()
    build_all(fmus)
    client, cluster = local_cluster(args.workers)
    print(f"machine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f}; local cluster of {args.workers} workers")
    try:
        with tempfile.TemporaryDirectory() as t:
            tmp = Path(t)
            if args.calibrate:
                calibrate(client, fmus, tmp, args.calibrate, [args.only] if args.only else NEEDLES)
                return
            if args.throughput:
                throughput(client, fmus, tmp, args.throughput, [args.only] if args.only else NEEDLES[:2])
                return
            tools = [t for t in args.tools.split(",") if t]
            if unknown := sorted(set(tools) - set(TOOLS)):
                raise SystemExit(f"--tools: unknown {', '.join(unknown)} (of {', '.join(TOOLS)})")
            if not args.no_cost:
                print(evaluation_cost(client, fmus, tmp, 5))
            total_sims, total_time = 0, 0.0
            curves: dict[str, list[float]] = {}
            for name in ([args.only] if args.only else NEEDLES):
                spec = load_spec(name, tmp)
                print(f"\n## {name}: {spec.requirements[0].formula}; {len(spec.dimensions)} dimensions; budget {args.budget}; "
                      f"{args.seeds} seeds")
                rows = []
                for opt in (t for t in TOOLS[:4] if t in tools):
                    firsts, started = [], time.perf_counter()
                    for seed in range(args.seeds):
                        out = run_search(spec, client, fmus, opt, seed, args.budget)
                        firsts.append(out.falsified_at)
                        total_sims += out.simulations
                        if seed == 0:
                            curves[f"{name}: {opt}"] = [r["robustness"] if r["robustness"] == r["robustness"] else math.inf
                                                        for r in out.rows]
                    wall = time.perf_counter() - started
                    total_time += wall
                    rows.append(row_of(f"tiltload {opt}", firsts, args.budget, wall))
                    print(f"  {rows[-1]}", flush=True)
                if not args.no_psy and ORACLE_PYTHON.is_file():
                    for kind in (t for t in TOOLS[4:] if t in tools):
                        started = time.perf_counter()
                        # its seeds side by side, one per worker (each still one sample at a time, as it evaluates)
                        with ThreadPoolExecutor(args.workers) as pool:
                            got = list(pool.map(lambda seed: psy_taliro(spec, client, fmus, kind, seed, args.budget),
                                                range(args.seeds)))
                        firsts = [first for first, _ in got]
                        print(f"  PSY-TaLiRo {kind} per seed: {[None if f is None else f + 1 for f in firsts]}", flush=True)
                        curves[f"{name}: PSY-TaLiRo {kind}"] = got[0][1]
                        rows.append(row_of(f"PSY-TaLiRo {kind}", firsts, args.budget, time.perf_counter() - started))
                        print(f"  {rows[-1]}", flush=True)
                print(table(rows, rows[0]["mean"] if rows and rows[0]["tool"] == "tiltload uniform" else math.nan))
            if total_time:
                print(f"\nthroughput: {total_sims} simulations in {total_time:.0f} s on the local cluster: "
                      f"{total_sims / total_time:.1f} simulations/s (tiltload's searches, batches included)")
            if curves:
                args.figure.parent.mkdir(parents=True, exist_ok=True)
                figure(curves, args.figure, "Best robustness against simulations (seed 0 of each)")
                print(f"figure: {args.figure}")
            if args.guaranteed:
                from tiltload.master.app.falsify.spec import load

                spec = load(SPECS / "zse_containment.toml")
                started = time.perf_counter()
                out = run_search(spec, client, fmus, "cmaes", 0, args.guaranteed)
                best = out.best
                seconds = time.perf_counter() - started
                verdict = (f"FALSIFIED at simulation {out.falsified_at + 1}" if out.falsified_at is not None
                           else f"not falsified in {out.simulations} simulations")
                print(f"\nguaranteed property (ZSE containment, CMA-ES): {verdict}; lowest robustness "
                      f"{best['robustness']:.4g} ({seconds:.0f} s, {out.simulations / seconds:.1f} simulations/s)")
    finally:
        client.close()
        cluster.close()


if __name__ == "__main__":

    main()

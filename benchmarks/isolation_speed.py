"""Issue 66's table: a controller FMU's cost per tick isolated (its own process, the default for an FMU tiltload did
not build) against in process (`--trust-fmus`), for three kinds of controller FMU on FSI and ZSE, this tree side by
side with another tree (e.g. the last landing, commit 5052690, with its own virtual environment) in one run.

  C controller        the shipped native controller FMU copied without its build record (a foreign C FMU that
                      follows docs/ports.md's contract)
  pythonfmu           docs/examples/hover_lqr_traced.py wrapped with `tiltload wrap` (pythonfmu)
  native wrap         the same class wrapped with `tiltload wrap --native` (a C FMU traced from Python)

The FMUs are built once, by this tree, and both trees run the same files on the thesis's loop (default_system with
controller_fmu, trajectory 0: hover; the shipped one in its own place, with its mixed design's parameters; no log).
Per tick: the wall time of a --stop s run / its ticks, after the instantiation and at least --warm s of simulated
and --warm-wall s of wall time (not timed). This VM's processor runs the same work at speeds up to 2x apart from one
second to the next (a bare Python loop on an idle machine: 6.9 to 12 µs an iteration), and a processor that was idle
runs slower for its first second or so of work, which an isolated run's worker (on the other processor) pays: the C
controller on FSI, the median of 10 runs, took 15.9 µs a tick isolated against 11.9 in process without the wall
warm-up, 14.0 against 12.4 with 1 s of it, 13.8 against 11.9 with 2 s (2026-12-07). So the runs are paired: in
process and isolated back to back, the order alternating pair by pair, and the ratio printed is the median of the
pairs' ratios (its quartiles below the table), beside the median per tick of each side. The machine (CPU, cores)
and its load average before and after go with the figures.

Run: python benchmarks/isolation_speed.py --before TREE --before-python PYTHON
         [--stop 30] [--warm 2] [--warm-wall 1] [--pairs 15]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "docs" / "examples" / "hover_lqr_traced.py"
KINDS = ("C controller", "pythonfmu", "native wrap")
SCENARIOS = ("fsi", "zse")


def foreign_copy(fmu: Path, dest: Path) -> Path:
    """The FMU without resources/build_info.json: tiltload no longer recognizes it as its own (it is isolated)."""
    with zipfile.ZipFile(fmu) as src, zipfile.ZipFile(dest, "w", zipfile.ZIP_DEFLATED) as out:
        for item in src.infolist():
            if item.filename != "resources/build_info.json":
                out.writestr(item, src.read(item.filename))
    return dest


def build(folder: Path) -> dict[str, Path]:
    """The three controllers and the loop's FMUs, built by this tree."""
    from tiltload.master.app.cli import main
    from tiltload.master.app.loop.fmus import build_all

    fmus = folder / "fmus"
    build_all(fmus)
    out = {"C controller": foreign_copy(fmus / "TiltloadController.fmu", folder / "CController.fmu")}
    # the example with np.clip for tl.saturate: a pythonfmu FMU calls tiltload at run time, and the older tree has no
    # tl.saturate (same values: tl.saturate is np.clip)
    source = folder / EXAMPLE.name
    source.write_text(EXAMPLE.read_text().replace("tl.saturate(u, self.u_min, self.u_max)", "np.clip(u, self.u_min, self.u_max)"))
    for kind, flags in (("pythonfmu", []), ("native wrap", ["--native"])):
        dest = folder / f"{kind.replace(' ', '_')}.fmu"
        if main(["wrap", *flags, str(source), "--out", str(dest)]) != 0:
            raise SystemExit(f"wrapping {EXAMPLE} ({kind}) failed")
        out[kind] = dest
    return {**out, "fmus": fmus}


def _loop_api():
    """default_system, loop_metrics, is_foreign and Execution from whichever tree this interpreter imports."""
    from tiltload.master.engine.execution import Execution

    try:
        from tiltload.master.app.loop.fmus import is_foreign
        from tiltload.master.app.loop.thesis import default_system, loop_metrics
    except ImportError:  # 5052690's layout
        from tiltload.master.app.fmus import is_foreign
        from tiltload.master.app.loop import default_system, loop_metrics
    return default_system, loop_metrics, is_foreign, Execution


def measure(config: dict) -> list[dict]:
    """In the tree this interpreter imports: every (kind, scenario, isolated) its per-tick cost and metrics. The loop
    is instantiated first (a worker started, the FMU loaded: not timed), then config["stop"] s run and timed."""
    import time

    default_system, loop_metrics, is_foreign, Execution = _loop_api()
    try:  # the tick loop's own profile (issue 66): the median tick, which a preempted tick does not move
        from tiltload.master.engine.profile import Profiler
    except ImportError:  # an older tree
        Profiler = None

    def timed(controller, scenario, isolated):
        if controller == config["C controller"]:  # the shipped controller's FMU, foreign: its design's parameters kept
            system = default_system(Path(config["fmus"]), scenario, 0, "mixed")
            next(i for i in system.instances if i.name == "controller").fmu = Path(controller)
        else:
            system = default_system(Path(config["fmus"]), scenario, 0, "mixed", controller_fmu=Path(controller))
        ex = Execution(system, [loop_metrics()], isolate=is_foreign if isolated else None)
        try:
            ex.instantiate()
            begun, t = time.perf_counter(), 0.0
            while t < config["warm"] or time.perf_counter() - begun < config["warm_wall"]:  # both processors at work
                t += 1.0
                ex.run(t)
            ticks = ex.ticks_done
            profiler = Profiler(ex) if Profiler is not None else None
            if profiler is not None:
                profiler.start()
            started = time.perf_counter()
            ex.run(t + config["stop"])
            wall = time.perf_counter() - started
            median = profiler.stop().tick_times.median if profiler is not None else float("nan")
            return wall / (ex.ticks_done - ticks), ex.observers[0].table(), median
        finally:
            ex.close()

    import statistics

    rows = []
    # warm: the first run of a process compiles or loads its kernels
    warm = time.perf_counter()
    while time.perf_counter() - warm < 15:
        timed(config["C controller"], "fsi", False)
    for kind in KINDS:
        for scenario in SCENARIOS:
            runs = {False: [], True: []}
            for pair in range(config["pairs"]):  # back to back, the order alternating: a drift hits both sides alike
                for isolated in ((False, True) if pair % 2 == 0 else (True, False)):
                    runs[isolated].append(timed(config[kind], scenario, isolated))
            ratios = sorted(b[0] / a[0] for a, b in zip(runs[False], runs[True]))
            quartiles = statistics.quantiles(ratios, n=4)
            for isolated, done in runs.items():
                per_tick = [r[0] * 1e6 for r in done]
                rows.append({"kind": kind, "scenario": scenario, "isolated": isolated,
                             "us_per_tick": statistics.median(per_tick), "spread": [min(per_tick), max(per_tick)],
                             "median_tick": statistics.median(r[2] * 1e6 for r in done), "metrics": done[0][1],
                             "ratio": statistics.median(ratios), "quartiles": [quartiles[0], quartiles[2]]})
    return rows


def machine() -> str:
    cpu = next((line.split(":", 1)[1].strip() for line in Path("/proc/cpuinfo").read_text().splitlines()
                if line.startswith("model name")), platform.processor()) if Path("/proc/cpuinfo").is_file() else platform.processor()
    return f"{platform.node()}: {cpu}, {os.cpu_count()} cores, {platform.system()} {platform.release()}"


def load() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    p.add_argument("--before", type=Path, help="the other tree (e.g. the last landing's worktree)")
    p.add_argument("--before-python", type=Path, help="its interpreter (tiltload installed from it)")
    p.add_argument("--stop", type=float, default=30.0, help="simulated s timed per run")
    p.add_argument("--warm", type=float, default=2.0, help="simulated s run first in each run, not timed")
    p.add_argument("--warm-wall", type=float, default=1.0, help="wall s each run works before it is timed (at least)")
    p.add_argument("--pairs", type=int, default=15, help="pairs of runs (in process, isolated) per row")
    p.add_argument("--measure", type=Path, default=None, help=argparse.SUPPRESS)  # a config: measure in this interpreter
    args = p.parse_args()
    if args.measure is not None:
        print(json.dumps(measure(json.loads(args.measure.read_text()))))
        return 0
    if args.before is None or args.before_python is None:
        p.error("--before and --before-python are required")
    if not args.before_python.is_file():
        p.error(f"--before-python {args.before_python}: no such interpreter")
    with tempfile.TemporaryDirectory(prefix="tl-isolation-speed-") as tmp:
        folder = Path(tmp)
        built = build(folder)
        config = {k: str(v) for k, v in built.items()} | {"stop": args.stop, "warm": args.warm, "pairs": args.pairs,
                                                          "warm_wall": args.warm_wall,
                                                          "out": str(folder / "runs")}
        (folder / "config.json").write_text(json.dumps(config))
        trees = {"this tree": (sys.executable, ROOT), f"before ({_commit(args.before)})": (str(args.before_python), args.before)}
        print(f"machine: {machine()}")
        results = {}
        for label, (python, root) in trees.items():
            print(f"load average before {label}: {load()}", flush=True)
            proc = subprocess.run([python, str(Path(__file__).resolve()), "--measure", str(folder / "config.json")],
                                  capture_output=True, text=True, cwd=root)
            if proc.returncode != 0:
                print(f"{label}: failed: {proc.stderr.strip().splitlines()[-1:]}")
                return 1
            results[label] = {(r["kind"], r["scenario"], r["isolated"]): r for r in json.loads(proc.stdout.splitlines()[-1])}
        print(f"load average after: {load()}")
        print(f"per tick of the whole loop, µs (no log; {args.stop:g} s timed per run after {args.warm_wall:g} s of wall "
              f"time; the median of {args.pairs} runs each side; ratio: the median of the pairs' ratios, isolated / in "
              "process)")
        head = f"{'controller':<14}{'scenario':<9}"
        for label in results:
            head += f"  | {label + ': in process':>28}{'isolated':>10}{'ratio':>7}"
        print(head)
        same = True
        for kind in KINDS:
            for scenario in SCENARIOS:
                line = f"{kind:<14}{scenario:<9}"
                for rows in results.values():
                    a, b = rows[(kind, scenario, False)], rows[(kind, scenario, True)]
                    same &= a["metrics"] == b["metrics"]
                    line += f"  | {a['us_per_tick']:>28.1f}{b['us_per_tick']:>10.1f}{b['ratio']:>7.2f}"
                print(line)
        print("the median tick (the tick loop's profile, µs; a tick preempted by another process does not move it):")
        for label, rows in results.items():
            if all(r["median_tick"] != r["median_tick"] for r in rows.values()):
                print(f"  {label}: no profile in this tree")
                continue
            for kind in KINDS:
                print(f"  {label}: {kind:<13}" + "".join(
                    f"  {sc} {rows[(kind, sc, False)]['median_tick']:.1f} -> {rows[(kind, sc, True)]['median_tick']:.1f}"
                    f" ({rows[(kind, sc, True)]['median_tick'] / rows[(kind, sc, False)]['median_tick']:.2f})"
                    for sc in SCENARIOS))
        print("the pairs' ratios, first and third quartiles:")
        for label, rows in results.items():
            print(f"  {label}: " + "; ".join(f"{k} {sc} {r['quartiles'][0]:.2f}-{r['quartiles'][1]:.2f}"
                                             for (k, sc, iso), r in rows.items() if iso))
        print("spread (min-max of the runs, µs a tick):")
        for label, rows in results.items():
            print(f"  {label}: " + "; ".join(
                f"{k} {sc} {'isolated' if iso else 'in process'} {r['spread'][0]:.1f}-{r['spread'][1]:.1f}"
                for (k, sc, iso), r in rows.items()))
        print(f"metrics isolated == in process in every row: {same}")
        shutil.rmtree(folder / "runs", ignore_errors=True)
        return 0 if same else 1


def _commit(root: Path) -> str:
    proc = subprocess.run(["git", "-C", str(root), "log", "-1", "--format=%h"], capture_output=True, text=True)
    return proc.stdout.strip() or str(root)


if __name__ == "__main__":
    sys.exit(main())

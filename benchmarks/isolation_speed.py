"""Issue 66's table: a controller FMU's cost per tick isolated (its own process, the default for an FMU tiltload did
not build) against in process (`--trust-fmus`), for three kinds of controller FMU on FSI and ZSE, this tree side by
side with another tree (e.g. the last landing, commit 5052690, with its own virtual environment) in one run.

  C controller        the shipped native controller FMU copied without its build record (a foreign C FMU that
                      follows docs/ports.md's contract)
  pythonfmu           docs/examples/hover_lqr_traced.py wrapped with `tiltload wrap` (pythonfmu)
  native wrap         the same class wrapped with `tiltload wrap --native` (a C FMU traced from Python)

The FMUs are built once, by this tree, and both trees run the same files on the thesis's loop (default_system with
controller_fmu, trajectory 0: hover; the shipped one in its own place, with its mixed design's parameters; no log).
Per tick: the wall time of --chunks chunks of --chunk simulated s / their ticks. Both sides of a row (in process and
isolated) are two executions in one process, instantiated first (a worker started, the FMU loaded: not timed), then
advanced to the same times in turn, one chunk each: first at least --warm simulated s and --warm-wall wall s untimed
(both processors at work), then the timed chunks, the order alternating chunk by chunk. This VM's processor runs the
same work at speeds up to 2x apart from one second to the next (a bare Python loop on an idle machine: 6.9 to 12 µs
an iteration; 15 pairs of whole runs back to back still gave quartiles of their ratios 0.96 to 1.50 for one row on
2026-12-07): chunks a few milliseconds long, interleaved, see the same machine, and both runs' metrics are of the same
horizon (checked equal). The ratio printed is the median of the chunk pairs' ratios (its quartiles below the table),
beside the per-tick cost of each side (all its chunks' wall time / their ticks). Where the tree has the tick loop's
profile (issue 66), its median tick and the isolation's own time a tick go below. The machine (CPU, cores) and its
load average before and after go with the figures.

Run: python benchmarks/isolation_speed.py --before TREE --before-python PYTHON
         [--chunk 5] [--chunks 60] [--warm 2] [--warm-wall 1]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
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
    """In the tree this interpreter imports: every (kind, scenario) its per-tick cost in process and isolated, and
    both runs' metrics. Both executions live side by side in this process (instantiated first: a worker started, the
    FMU loaded; not timed) and advance to the same times in turn, a chunk of config["chunk"] simulated s each: first
    untimed (at least config["warm"] simulated and config["warm_wall"] wall s), then config["chunks"] chunks each timed,
    the order alternating chunk by chunk. A drift of this VM's speed over more than a chunk's few milliseconds of wall
    time then hits both sides alike, and both runs' metrics are of the same horizon."""
    import statistics
    import time

    default_system, loop_metrics, is_foreign, Execution = _loop_api()
    try:  # the tick loop's own profile (issue 66): the median tick, which a preempted tick does not move
        from tiltload.master.engine.profile import Profiler
    except ImportError:  # an older tree
        Profiler = None

    def execution(controller, scenario, isolated):
        if controller == config["C controller"]:  # the shipped controller's FMU, foreign: its design's parameters kept
            system = default_system(Path(config["fmus"]), scenario, 0, "mixed")
            next(i for i in system.instances if i.name == "controller").fmu = Path(controller)
        else:
            system = default_system(Path(config["fmus"]), scenario, 0, "mixed", controller_fmu=Path(controller))
        return Execution(system, [loop_metrics()], isolate=is_foreign if isolated else None)

    def row(kind, scenario):
        sides = {}
        try:
            for isolated in (False, True):
                sides[isolated] = execution(config[kind], scenario, isolated)
                sides[isolated].instantiate()
            begun, t = time.perf_counter(), 0.0
            while t < config["warm"] or time.perf_counter() - begun < config["warm_wall"]:  # both processors at work
                t += config["chunk"]
                for ex in sides.values():
                    ex.run(t)
            ticks = sides[False].ticks_done
            profilers = {iso: Profiler(ex) for iso, ex in sides.items()} if Profiler is not None else {}
            for profiler in profilers.values():
                profiler.start()
            walls = {False: [], True: []}
            stolen = {False: 0.0, True: 0.0}
            for chunk in range(config["chunks"]):
                t += config["chunk"]
                for isolated in ((False, True) if chunk % 2 == 0 else (True, False)):
                    before, started = steal(), time.perf_counter()
                    sides[isolated].run(t)
                    walls[isolated].append(time.perf_counter() - started)
                    stolen[isolated] += steal() - before
            ticks = sides[False].ticks_done - ticks
            assert sides[True].ticks_done - sides[False].ticks_done == 0, "both sides run the same ticks"
            profiles = {iso: p.stop() for iso, p in profilers.items()}
            ratios = sorted(b / a for a, b in zip(walls[False], walls[True]))
            quartiles = statistics.quantiles(ratios, n=4)
            out = []
            for isolated, ex in sides.items():
                profile = profiles.get(isolated)
                out.append({"kind": kind, "scenario": scenario, "isolated": isolated,
                            "us_per_tick": sum(walls[isolated]) / ticks * 1e6, "ticks": ticks,
                            "fastest": min(walls[isolated]) / (ticks / config["chunks"]) * 1e6,
                            "median_tick": profile.tick_times.median * 1e6 if profile else float("nan"),
                            "isolation_per_tick": (sum(f.isolation for f in profile.fmus) / ticks * 1e6
                                                   if profile else float("nan")),
                            "steal": stolen[isolated] / sum(walls[isolated]),
                            "metrics": ex.observers[0].table(), "ratio": statistics.median(ratios),
                            "quartiles": [quartiles[0], quartiles[2]]})
            return out
        finally:
            for ex in sides.values():
                ex.close()

    rows = []
    # warm: the first run of a process compiles or loads its kernels
    warm = time.perf_counter()
    while time.perf_counter() - warm < 15:
        ex = execution(config["C controller"], "fsi", False)
        try:
            ex.instantiate()
            ex.run(30.0)
        finally:
            ex.close()
    for kind in KINDS:
        for scenario in SCENARIOS:
            rows += row(kind, scenario)
    return rows


def steal() -> float:
    """Seconds the hypervisor has run something else while this VM's processors wanted to run (/proc/stat's steal,
    every processor; 0 where there is none)."""
    try:
        fields = Path("/proc/stat").read_text().split("\n", 1)[0].split()
        return int(fields[8]) / os.sysconf("SC_CLK_TCK")
    except (OSError, IndexError, ValueError):
        return 0.0


def machine() -> str:
    cpu = next((line.split(":", 1)[1].strip() for line in Path("/proc/cpuinfo").read_text().splitlines()
                if line.startswith("model name")), platform.processor()) if Path("/proc/cpuinfo").is_file() else platform.processor()
    return f"{platform.node()}: {cpu}, {os.cpu_count()} cores, {platform.system()} {platform.release()}"


def load() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def _at_least(low: float, kind=float):
    def parse(text: str):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
        if not value >= low:  # NaN too
            raise argparse.ArgumentTypeError(f"{text} is less than {low:g}")
        return value
    return parse


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    p.add_argument("--before", type=Path, help="the other tree (e.g. the last landing's worktree)")
    p.add_argument("--before-python", type=Path, help="its interpreter (tiltload installed from it)")
    p.add_argument("--chunk", type=_at_least(0.1), default=5.0, help="simulated s of one timed chunk (default 5)")
    p.add_argument("--chunks", type=_at_least(4, int), default=60, help="timed chunks each side per row (default 60)")
    p.add_argument("--warm", type=_at_least(0.0), default=2.0, help="simulated s run first, not timed (at least)")
    p.add_argument("--warm-wall", type=_at_least(0.0), default=1.0, help="wall s both sides work before the timing (at least)")
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
        config = {k: str(v) for k, v in built.items()} | {"chunk": args.chunk, "chunks": args.chunks, "warm": args.warm,
                                                          "warm_wall": args.warm_wall}
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
        print(f"per tick of the whole loop, µs (no log; {args.chunks} chunks of {args.chunk:g} simulated s each side, in "
              "process and isolated in turn in one process; ratio: the median of the chunk pairs' ratios, isolated / "
              "in process)")
        head = f"{'controller':<14}{'scenario':<9}"
        for label in results:
            head += f"  | {label + ': in process':>28}{'isolated':>10}{'ratio':>7}"
        print(head)
        different = []
        for kind in KINDS:
            for scenario in SCENARIOS:
                line = f"{kind:<14}{scenario:<9}"
                for label, rows in results.items():
                    a, b = rows[(kind, scenario, False)], rows[(kind, scenario, True)]
                    if a["metrics"] != b["metrics"]:
                        different.append(f"{label} {kind} {scenario}")
                    line += f"  | {a['us_per_tick']:>28.1f}{b['us_per_tick']:>10.1f}{b['ratio']:>7.2f}"
                print(line)
        print("the chunk pairs' ratios, first and third quartiles:")
        for label, rows in results.items():
            print(f"  {label}: " + "; ".join(f"{k} {sc} {r['quartiles'][0]:.2f}-{r['quartiles'][1]:.2f}"
                                             for (k, sc, iso), r in rows.items() if iso))
        print("each side's fastest chunk (µs a tick: the cost with the least interference, as timeit's minimum), in "
              "process -> isolated (ratio):")
        for label, rows in results.items():
            fastest = {key: r["fastest"] for key, r in rows.items()}
            print(f"  {label}: " + "; ".join(
                f"{k} {sc} {fastest[(k, sc, False)]:.1f} -> {f:.1f} ({f / fastest[(k, sc, False)]:.2f})"
                for (k, sc, iso), f in fastest.items() if iso))
        print("the hypervisor's steal during the timed chunks (/proc/stat: time this VM's processors wanted to run and did "
              "not, over the chunks' wall time; 100 % = one processor's worth), in process / isolated:")
        for label, rows in results.items():
            print(f"  {label}: " + "; ".join(
                f"{k} {sc} {rows[(k, sc, False)]['steal']:.0%} / {rows[(k, sc, True)]['steal']:.0%}"
                for (k, sc, iso) in rows if iso))
        print("the tick loop's profile (µs): median tick in process -> isolated, and the isolation's own time a tick "
              "(the round trips less the host's time in the FMU's calls):")
        for label, rows in results.items():
            if all(r["median_tick"] != r["median_tick"] for r in rows.values()):
                print(f"  {label}: no profile in this tree")
                continue
            for kind in KINDS:
                print(f"  {label}: {kind:<13}" + "".join(
                    f"  {sc} {rows[(kind, sc, False)]['median_tick']:.1f} -> {rows[(kind, sc, True)]['median_tick']:.1f}"
                    f" (isolation {rows[(kind, sc, True)]['isolation_per_tick']:.2f})" for sc in SCENARIOS))
        print("metrics isolated == in process (the same horizon) in every row: "
              + ("True" if not different else f"False ({', '.join(different)})"))
        return 0 if not different else 1


def _commit(root: Path) -> str:
    proc = subprocess.run(["git", "-C", str(root), "log", "-1", "--format=%h"], capture_output=True, text=True)
    return proc.stdout.strip() or str(root)


if __name__ == "__main__":
    sys.exit(main())

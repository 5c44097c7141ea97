"""Campaign throughput of the native tick loop on 1 and 2 workers, for FSI and ZSE, and where a campaign's time goes;
optionally the code of another commit measured side by side (--before main).

For each scenario (trajectory 1, mixed H2/Hinf design, --stop s per run, no log, the campaign's metrics) a campaign of
--runs seeds runs on the project's campaign runner (master/app/campaign/runner.py: a Dask LocalCluster of 1, then 2
worker processes, one thread each). Each measurement is a fresh Python process (the code under test imported from its
tree), so the trees and worker counts are measured alike, taken in turn (a shared machine's load drifts):

- serial: the same cases run one after the other in that process (warm: the FMUs instantiated once and reset between
  runs, a warm-up run apart), before and after the campaign; `serial` = N x the mean wall time of such a run;
- wall: the campaign's seconds from the first submission to the last result (the cluster's start and stop apart);
- parallel efficiency = serial / (workers x wall): 1.0 when N workers each keep the pace of one process alone.

And where the time went, measured by wrapping the runner's task and the engine's Execution.run (the same probe on
every tree): per run, the worker's CPU inside Execution.run (the simulation) against its task's other CPU (FMU
unpack, instantiation or reset, metrics); each worker's timeline (before its first run, between runs: Dask's
messages, (de)serialization; after its last); the worker processes' CPU outside the runs; the client process's CPU
(its main thread: dispatch and the Parquet parts; its other threads: the LocalCluster's scheduler and Dask's
comms); the machine's busy CPU over the campaign (/proc/stat), ours and others'. Load-independent figures: the
workers' busy fraction = sum of in-simulation CPU / (workers x wall), and the CPU per run (all our processes).

First, per tree (and round, the trees in turn), a worker's per-run set-up in one process: --setup-runs of the
campaign's cases run one after the other on one execution restarted each time, and this thread's CPU per run in
Execution.restart (fmi2Reset/fmi3Reset, initialization, the tick loop's plan) and in the task outside Execution.run.

With --ceiling R, first, per scenario: R rounds of one process running warm runs alone, then two processes running as
many each at the same time (no Dask, no scheduler): alone / at-once CPU per run is the most a 2-worker campaign's
efficiency can reach on this machine, whose two cores slow each other's runs down (shared caches, memory, the host).

Run: python benchmarks/campaign_native.py [--runs 48] [--stop 40] [--workers 1 2] [--before main] [--quick]
     [--setup-runs 40] [--setup-only] [--ceiling 5]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import threading
import time
import tomllib
from dataclasses import asdict
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent

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


# ---- the probe: runs in the measuring process and in its workers (imported there by name: campaign_native) --------

def _patch_execution() -> None:
    """Execution.run timed into class attributes (CPU of this thread, wall): the simulation's own cost."""
    from tiltload.master.engine.execution import Execution

    if getattr(Execution, "_probe_cpu", None) is not None:
        return
    run = Execution.run

    def timed_run(self, stop, realtime=None):
        c, w = time.thread_time(), time.perf_counter()
        try:
            return run(self, stop, realtime)
        finally:
            Execution._probe_cpu += time.thread_time() - c
            Execution._probe_wall += time.perf_counter() - w
    Execution._probe_cpu, Execution._probe_wall = 0.0, 0.0
    Execution.run = timed_run


def probed_run_case(*args, **kwargs):
    """The runner's task, with what it cost: its outcome plus "_probe" (pid, start/end epoch, CPU in and around the
    simulation, the worker process's CPU at start and end)."""
    from tiltload.master.app.campaign import run_case as module
    from tiltload.master.engine.execution import Execution

    _patch_execution()
    original = getattr(module, "_probe_original", module.run_case)
    t0, c0, p0 = time.time(), time.thread_time(), time.process_time()
    s0, sw0 = Execution._probe_cpu, Execution._probe_wall
    result = original(*args, **kwargs)
    if "row" in result:
        result = {**result, "_probe": {"pid": os.getpid(), "start": t0, "end": time.time(), "cpu": time.thread_time() - c0,
                                       "sim_cpu": Execution._probe_cpu - s0, "sim_wall": Execution._probe_wall - sw0,
                                       "setup": result.get("setup", 0.0),
                                       "proc0": p0, "proc1": time.process_time()}}
    return result


def _thread_cpu() -> dict[int, float]:
    """CPU seconds of each thread of this process (/proc/self/task: utime + stime)."""
    ticks = os.sysconf("SC_CLK_TCK")
    out = {}
    for task in Path("/proc/self/task").iterdir():
        try:
            fields = (task / "stat").read_text().rsplit(")", 1)[1].split()
            out[int(task.name)] = (int(fields[11]) + int(fields[12])) / ticks
        except (OSError, IndexError, ValueError):
            pass
    return out


def _machine_cpu() -> tuple[float, float]:
    """(busy, all) CPU seconds of the whole machine so far (/proc/stat)."""
    values = [int(v) for v in Path("/proc/stat").read_text().splitlines()[0].split()[1:]]
    ticks = os.sysconf("SC_CLK_TCK")
    return (sum(values) - values[3] - values[4]) / ticks, sum(values) / ticks


def _serial(spec: Path, fmus: Path, n: int) -> list[tuple[float, float]]:
    """(wall, CPU) of n of the campaign's cases run one after the other here, after one warm-up run (as a worker runs
    them: the FMUs instantiated once, reset between runs); each must complete."""
    from tiltload.master.app.campaign import run_case as module
    from tiltload.master.app.campaign.spec import load

    c = load(spec)
    run_case = getattr(module, "_probe_original", module.run_case)
    out = []
    for k, case in enumerate([asdict(x) for x in c.cases[:n + 1]]):
        t0, c0 = time.perf_counter(), time.thread_time()
        result = run_case(c.base(), case, str(fmus.resolve()), None)
        if not result["row"]["completed"]:
            raise SystemExit(f"run {case['run_id']} failed: {result['row']['error']}")
        if k:
            out.append((time.perf_counter() - t0, time.thread_time() - c0))
    return out


def measure_serial(spec: str, fmus: str, n: int, start_at: float) -> list[tuple[float, float]]:
    """_serial's (wall, CPU) of n runs here, begun at the epoch start_at (after the imports and the warm-up run), so that
    two processes given the same start_at run theirs at the same time."""
    from tiltload.master.app.campaign import run_case as module
    from tiltload.master.app.campaign.spec import load

    c = load(Path(spec))
    module.run_case(c.base(), asdict(c.cases[0]), str(Path(fmus).resolve()), None)  # the warm-up
    time.sleep(max(0.0, start_at - time.time()))
    return _serial(Path(spec), Path(fmus), n)


def measure_setup(spec: str, fmus: str, n: int) -> dict:
    """The per-run set-up of a worker, serially here: n of the campaign's cases after a warm-up run, each on the one
    execution restarted (as a worker runs them); per run, this thread's CPU in Execution.restart and in the task
    outside Execution.run (describing the case, checking it, the restart, the observers' finish, the row)."""
    from tiltload.master.app.campaign import run_case as module
    from tiltload.master.app.campaign.spec import load
    from tiltload.master.app.loop.fmus import build_all
    from tiltload.master.engine.execution import Execution

    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    build_all(Path(fmus), progress=lambda _: None)
    _patch_execution()
    restart, spent = Execution.restart, []

    def timed_restart(self, *args, **kwargs):
        c = time.thread_time()
        try:
            return restart(self, *args, **kwargs)
        finally:
            spent.append(time.thread_time() - c)
    Execution.restart = timed_restart
    c = load(Path(spec))
    cases = [asdict(x) for x in c.cases]
    module.run_case(c.base(), cases[0], str(Path(fmus).resolve()), None)  # the warm-up: instantiation, imports
    spent.clear()
    outside = []
    for k in range(n):
        c0, s0 = time.thread_time(), Execution._probe_cpu
        result = module.run_case(c.base(), cases[1 + k % (len(cases) - 1)], str(Path(fmus).resolve()), None)
        if not result["row"]["completed"]:
            raise SystemExit(f"run {result['row']['run_id']} failed: {result['row']['error']}")
        outside.append(time.thread_time() - c0 - (Execution._probe_cpu - s0))
    return {"restart": spent, "outside": outside}


def measure(spec: str, out: str, fmus: str, workers: int, alone: int) -> dict:
    """One campaign on `workers` local workers with the probe, and the serial runs around it: the figures, a dict."""
    from tiltload.master.app.batch import dispatch
    from tiltload.master.app.campaign import run_case as module
    from tiltload.master.app.campaign import runner

    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    spec_path, fmu_dir = Path(spec), Path(fmus)
    from tiltload.master.app.loop.fmus import build_all

    build_all(fmu_dir, progress=lambda _: None)
    module._probe_original = module.run_case
    module.run_case = probed_run_case
    probes, writes = [], [0, 0.0]
    window: dict = {}
    write_part = runner.write_part

    def timed_write(folder, result):
        t = time.perf_counter()
        write_part(folder, result)
        writes[0] += 1
        writes[1] += time.perf_counter() - t
        probes.append(result.get("_probe"))
    runner.write_part = timed_write
    if hasattr(runner, "write_parts"):  # a tree that writes several outcomes a part
        write_parts = runner.write_parts

        def timed_writes(folder, results):
            t = time.perf_counter()
            write_parts(folder, results)
            writes[0] += 1
            writes[1] += time.perf_counter() - t
            probes.extend(r.get("_probe") for r in results)
        runner.write_parts = timed_writes
    run = dispatch.Dispatch.run

    def timed_dispatch(self, cases):
        main = threading.main_thread().native_id
        before, machine0 = _thread_cpu(), _machine_cpu()
        load0, t0, epoch = os.getloadavg()[0], time.perf_counter(), time.time()
        try:
            return run(self, cases)
        finally:
            wall = time.perf_counter() - t0
            after, machine1 = _thread_cpu(), _machine_cpu()
            spent = {tid: after[tid] - before.get(tid, 0.0) for tid in after}
            window.update(wall=wall, epoch=epoch, client_main=spent.get(main, 0.0),
                          client_other=sum(v for k, v in spent.items() if k != main),
                          machine_busy=machine1[0] - machine0[0], machine_all=machine1[1] - machine0[1],
                          load=(load0 + os.getloadavg()[0]) / 2)
    dispatch.Dispatch.run = timed_dispatch
    serial_before = _serial(spec_path, fmu_dir, alone)
    _, counts = runner.run(spec_path, Path(out), workers=workers, fmus=fmu_dir, progress=lambda _: None)
    serial_after = _serial(spec_path, fmu_dir, alone)
    if counts["failed"]:
        raise SystemExit(f"{counts['failed']} of the campaign's runs failed")
    return {"workers": workers, "runs": counts["ran"], "seconds": counts["seconds"], "serial": serial_before + serial_after,
            "probes": [p for p in probes if p], "writes": writes, **window}


# ---- the orchestrator ----------------------------------------------------------------------------------------------

def _tree(rev: str, folder: Path) -> Path:
    """The commit's code, importable as `tiltload` from the returned folder (on PYTHONPATH): its files exported, and a
    package folder that maps tiltload.* to them as its pyproject's package-dir does."""
    src = folder / "src"
    src.mkdir(parents=True)
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", rev], capture_output=True, check=True).stdout
    subprocess.run(["tar", "-x", "-C", str(src)], input=archive, check=True)
    dirs = tomllib.loads((src / "pyproject.toml").read_text())["tool"]["setuptools"]["package-dir"]
    shim = folder / "shim" / "tiltload"
    shim.mkdir(parents=True)
    for entry in (src / dirs.get("tiltload", "tiltload")).iterdir():
        (shim / entry.name).symlink_to(entry)
    for name, where in dirs.items():
        if name.count(".") == 1:
            (shim / name.split(".")[1]).symlink_to(src / where)
    return folder / "shim"


def _start(call: str, path: Path | None, cwd: Path) -> subprocess.Popen:
    """A fresh Python process printing 'RESULT <json>' of campaign_native.<call>, with the tree at path (None: the
    installed one) importable as tiltload; cwd not the repository, whose tiltload/ folder would shadow the tree."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(HERE), *([str(path)] if path else [])]))
    code = f"import json, campaign_native as b; print('RESULT ' + json.dumps(b.{call}))"
    return subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=env, cwd=str(cwd))


def _result(what: str, proc: subprocess.Popen):
    """The JSON a process of _start printed; the end of its stderr if it failed."""
    stdout, stderr = proc.communicate()
    line = next((x for x in stdout.splitlines() if x.startswith("RESULT ")), None)
    if proc.returncode or line is None:
        raise SystemExit(f"{what} failed:\n{stderr[-3000:]}")
    return json.loads(line[7:])


def _one(label: str, path: Path | None, spec: Path, out: Path, fmus: Path, workers: int, alone: int) -> dict:
    call = f"measure({str(spec)!r}, {str(out)!r}, {str(fmus)!r}, {workers}, {alone})"
    return _result(f"{label}: the measurement", _start(call, path, out.parent))


def _setup(label: str, path: Path | None, spec: Path, fmus: Path, n: int) -> dict:
    call = f"measure_setup({str(spec)!r}, {str(fmus)!r}, {n})"
    return _result(f"{label}: the set-up measurement", _start(call, path, spec.parent))


def _at_once(spec: Path, fmus: Path, n: int, processes: int) -> list[list[tuple[float, float]]]:
    """Each of `processes` processes' (wall, CPU) of n runs, the processes running theirs at the same time."""
    start_at = time.time() + 6.0  # past the imports and the warm-up run of every process
    call = f"measure_serial({str(spec)!r}, {str(fmus)!r}, {n}, {start_at!r})"
    procs = [_start(call, None, spec.parent) for _ in range(processes)]
    return [_result("the runs at once", proc) for proc in procs]


def ceiling_report(scenario: str, spec: Path, fmus: Path, n: int, rounds: int) -> str:
    """What two runs at once cost each, against one alone, with no Dask: rounds of one process running n of the
    campaign's runs alone, then two processes running n each at the same time. Alone/at-once CPU per run is the most a
    2-worker campaign's parallel efficiency can reach on this machine (its cores slow each other down)."""
    import statistics

    lines, ratios = [f"{scenario.upper()}, two runs at once against one alone (no Dask; {n} warm runs a process, "
                     f"{rounds} rounds, thread CPU per run, median):"], []
    for k in range(rounds):
        (alone,) = _at_once(spec, fmus, n, 1)
        pair = _at_once(spec, fmus, n, 2)
        one = statistics.median(c for _, c in alone)
        each = [statistics.median(c for _, c in runs) for runs in pair]
        ratios.append(one / _mean(each))
        lines.append(f"  round {k + 1}: alone {one * 1e3:.1f} ms; at once {' and '.join(f'{e * 1e3:.1f}' for e in each)}"
                     f" ms -> {ratios[-1]:.2f}; load {os.getloadavg()[0]:.1f}")
    lines.append(f"  the ceiling of a 2-worker campaign's efficiency here: {statistics.median(ratios):.2f} (median of "
                 f"{len(ratios)}, range {min(ratios):.2f}-{max(ratios):.2f})")
    return "\n".join(lines)


def setup_report(scenario: str, measured: list[tuple[str, dict]]) -> str:
    """Per tree, the median and mean per-run CPU of Execution.restart and of the task outside the simulation."""
    import statistics

    lines = [f"{scenario.upper()}, per-run set-up of a worker (serially, one process; thread CPU, median / mean of "
             f"{len(measured[0][1]['restart'])} runs x {len(measured) // len(dict(measured))} rounds):"]
    by_tree: dict[str, dict] = {}
    for label, r in measured:
        tree = by_tree.setdefault(label, {"restart": [], "outside": []})
        tree["restart"] += r["restart"]
        tree["outside"] += r["outside"]
    for label, r in by_tree.items():
        lines.append(f"  {label}: Execution.restart {statistics.median(r['restart']) * 1e6:.0f} / "
                     f"{_mean(r['restart']) * 1e6:.0f} us; the task outside the simulation "
                     f"{statistics.median(r['outside']) * 1e6:.0f} / {_mean(r['outside']) * 1e6:.0f} us")
    return "\n".join(lines)


def _mean(values) -> float:
    values = list(values)
    return sum(values) / len(values) if values else float("nan")


def report(label: str, scenario: str, r: dict) -> str:
    n, w, wall = r["runs"], r["workers"], r["seconds"]
    run_wall = _mean(s[0] for s in r["serial"])
    run_cpu = _mean(s[1] for s in r["serial"])
    serial = n * run_wall
    probes = r["probes"]
    sim_cpu = sum(p["sim_cpu"] for p in probes)
    task_cpu = sum(p["cpu"] for p in probes)
    by_worker: dict[int, list] = {}
    for p in probes:
        by_worker.setdefault(p["pid"], []).append(p)
    start, last = r["epoch"], r["epoch"] + r["wall"]  # the dispatch's span
    lead = gaps = tail = worker_cpu = in_tasks = 0.0
    cold = []
    for runs in by_worker.values():
        runs.sort(key=lambda p: p["start"])
        lead += runs[0]["start"] - start
        gaps += sum(b["start"] - a["end"] for a, b in zip(runs, runs[1:]))
        tail += last - runs[-1]["end"]
        worker_cpu += runs[-1]["proc1"] - runs[0]["proc0"]
        in_tasks += sum(p["cpu"] for p in runs)
        cold.append((runs[0]["cpu"] - runs[0]["sim_cpu"], runs[0].get("setup", float("nan"))))
    ours = worker_cpu + r["client_main"] + r["client_other"]
    others = max(r["machine_busy"] - ours, 0.0)
    cores = r["machine_all"] / r["wall"] if r["wall"] else float("nan")
    return "\n".join([
        f"{scenario.upper()}, {w} worker(s), {label}: {n} runs in {wall:.2f} s; serial {n} x {run_wall * 1e3:.1f} ms = "
        f"{serial:.2f} s; parallel efficiency {serial / (w * wall):.2f}; load {r['load']:.1f}",
        f"  workers' busy fraction (in-simulation CPU / workers x wall) {sim_cpu / (w * wall):.2f}; CPU per run: "
        f"simulation {sim_cpu / n * 1e3:.1f} ms, the task's other {(task_cpu - sim_cpu) / n * 1e3:.2f} ms (a worker's "
        f"first: {_mean(c for c, _ in cold) * 1e3:.0f} ms CPU, {_mean(w for _, w in cold) * 1e3:.0f} ms wall to unpack, "
        f"load and instantiate), all our processes {ours / n * 1e3:.1f} ms (the simulation's share {sim_cpu / ours:.2f}); "
        f"serial run in one process {run_cpu * 1e3:.1f} ms CPU",
        f"  worker timeline (sums over {len(by_worker)} workers, of {w * wall:.2f} worker-s): in runs "
        f"{sum(p['end'] - p['start'] for p in probes):.2f} s, before the first {lead:.2f} s, between runs {gaps:.2f} s "
        f"({gaps / max(n - len(by_worker), 1) * 1e3:.1f} ms each), after the last {tail:.2f} s; worker processes' "
        f"CPU outside the runs {worker_cpu - in_tasks:.2f} s",
        f"  client process CPU: main thread {r['client_main']:.2f} s (Parquet parts {r['writes'][1]:.2f} s wall in "
        f"{r['writes'][0]} writes), scheduler and comms threads {r['client_other']:.2f} s; machine: {r['machine_busy']:.2f} "
        f"of {r['machine_all']:.2f} CPU-s busy ({cores:.1f} cores), ours {ours:.2f}, others' {others:.2f}"])


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    p.add_argument("--runs", type=int, default=48, help="runs per campaign (seeds 1..N), default 48")
    p.add_argument("--stop", type=float, default=40.0, help="s per run, default 40")
    p.add_argument("--workers", type=int, nargs="+", default=[1, 2], help="worker counts, default 1 2")
    p.add_argument("--alone", type=int, default=4, help="runs timed serially before and after each campaign, default 4")
    p.add_argument("--scenarios", nargs="+", choices=("fsi", "lkf", "zse"), default=["fsi", "zse"])
    p.add_argument("--before", default=None, help="a commit (e.g. main) measured side by side with this tree")
    p.add_argument("--rounds", type=int, default=1, help="times each measurement is taken (in turn), default 1")
    p.add_argument("--quick", action="store_true", help="6 runs of 10 s, 2 timed serially: shows the script works")
    p.add_argument("--setup-runs", type=int, default=40,
                   help="runs whose set-up (restart, the task outside the simulation) is timed serially per tree and "
                        "round before the campaigns, default 40; 0: none")
    p.add_argument("--setup-only", action="store_true", help="only the set-up measurement, no campaigns")
    p.add_argument("--ceiling", type=int, default=0, metavar="ROUNDS",
                   help="first, ROUNDS rounds of two processes running runs at once against one alone (no Dask): the "
                        "most a 2-worker campaign's efficiency can reach on this machine; default 0: not measured")
    args = p.parse_args()
    runs, stop, alone = (6, 10.0, 2) if args.quick else (args.runs, args.stop, args.alone)
    if (runs < 1 or stop <= 0 or alone < 1 or args.rounds < 1 or min(args.workers) < 1 or args.setup_runs < 0
            or args.ceiling < 0):
        p.error("--runs, --alone, --rounds and --workers must be >= 1, --setup-runs and --ceiling >= 0 and --stop > 0")
    if args.setup_only and not args.setup_runs:
        p.error("--setup-only needs --setup-runs >= 1")
    sys.path.insert(0, str(HERE))
    from timing import machine

    print(f"{machine()}\n{runs} runs of {stop:g} s per campaign (trajectory 1, mixed design, seeds 1..{runs}, no log)\n",
          flush=True)
    with tempfile.TemporaryDirectory() as t:
        tmp = Path(t)
        trees = [("this tree", None, ROOT / "fmus")]
        if args.before:
            rev = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", args.before], capture_output=True,
                                 text=True, check=True).stdout.strip()
            trees.insert(0, (f"{args.before} ({rev})", _tree(args.before, tmp / "before"), tmp / "fmus-before"))
        for scenario in args.scenarios:
            spec = tmp / f"{scenario}.toml"
            spec.write_text(SPEC.format(scenario=scenario, stop=stop, seeds=", ".join(str(s) for s in range(1, runs + 1))))
            if args.ceiling:
                from tiltload.master.app.loop.fmus import build_all

                build_all(trees[-1][2], progress=lambda _: None)
                print(ceiling_report(scenario, spec, trees[-1][2], max(alone, 8), args.ceiling), flush=True)
            if args.setup_runs:  # the trees in turn, round after round (a shared machine's load drifts)
                measured = [(label, _setup(label, path, spec, fmus, args.setup_runs))
                            for _ in range(args.rounds) for label, path, fmus in trees]
                print(setup_report(scenario, measured), flush=True)
                if args.setup_only:
                    print()
                    continue
            for workers in args.workers:
                for k in range(args.rounds):
                    for label, path, fmus in trees:
                        out = tmp / f"{scenario}-w{workers}-{k}-{len(label)}"
                        print(report(label, scenario, _one(label, path, spec, out, fmus, workers, alone)), flush=True)
                print()
    print(f"load average at the end: {', '.join(f'{x:.1f}' for x in os.getloadavg())} (on {os.cpu_count()} cores)")


if __name__ == "__main__":
    main()

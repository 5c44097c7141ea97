"""Loop throughput per scenario against the FMUs' own C cost, libcosim and a native container of the same FMUs.

Per scenario (FSI, LKF, ZSE; trajectory 1, mixed H2/Hinf design, OpenBLAS single-threaded), printed:
1. ours with the full MCAP log (as `tiltload run`) and with no log (metrics only, as a campaign): us per tick, x RT;
2. the FMUs' own C cost per tick: the time the C tick loop measured around each FMU's set, doStep and get calls (summed,
   and per FMU), in the no-log run; the ratios no-log / C cost (target <= 1.15) and full log / C cost (<= 1.5);
3. libcosim (libcosimpy, same process, a last-value observer) on the SSP package exported for a Jacobi master, against
   ours running the same package the same way (`tiltload run --system` of it: jacobi.explicit), no observer: target
   libcosim / ours >= 2 for FSI and LKF (ZSE stated); and how far apart the two plants end (they are not the same
   arithmetic: libcosim's Jacobi step is reproduced, not its every rounding);
4. the fmu-manipulation-toolbox's container of the same four FMUs (fmu_container.py: built from the ordered package,
   sequential, run by FMPy) against ours on that package, no observer: target container / ours >= 1; and whether the
   plants end bit for bit equal.
5. with --before COMMIT (issue 41): the no-log loop with that commit's plant and controller FMUs (built from its code by
   fmu_arithmetic.build_tree) and with this tree's, the sensors and scenario this tree's in both, in turn: x RT and the
   FMUs' C cost per tick side by side, and whether the runs end bit for bit equal.
Every master runs the same whole number of ticks (stop / tick, rounded); instantiation and initialization are not
timed, finishing the log is; each figure is the best of --repeat runs (the machine is shared: the least disturbed
run), taken in turn. Our full-log and no-log runs time every FMU call (the C cost: two clock reads per step, in the
figures); our runs against libcosim and the container do not, as neither of those does (and a user's run does not).

Run: pip install -e ".[bench]" && python benchmarks/cosim.py [--stop 20] [--repeat 3] [--quick] [--before b93cc50]
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import fmu_container
import libcosim_master
import numpy as np
from tiltload.controller_fmu.design.cache import cache_root
from tiltload.master.app.loop.fmus import build_all
from tiltload.master.app.loop.scene import scene_channels
from tiltload.master.app.loop.thesis import TICK, default_system, loop_metrics, select_loop_delay
from tiltload.master.engine import jacobi
from tiltload.master.engine.fmi.model_description import read_fmu
from tiltload.master.engine.log.logger import McapLogger
from tiltload.master.engine.ssp.export import export
from tiltload.master.engine.ssp.load import load
from timing import Timed, best, machine, timed

UNPACK = cache_root() / "ssp"  # where packages are unpacked, as tiltload run does
SCENARIOS = ("fsi", "lkf", "zse")
TARGETS = {"nolog": 1.15, "log": 1.5, "libcosim": 2.0, "container": 1.0}


def package(fmus: Path, scenario: str, schedule: str, folder: Path, stop: float):
    """The loop exported for a master of this schedule, and the system ours runs of it (as tiltload run --system)."""
    system = default_system(fmus, scenario, 1, "mixed")
    select_loop_delay(system, schedule)
    path = export(system, folder / f"{scenario}-{schedule}.ssp", stop, schedule)
    loaded, _, _ = load(path, UNPACK)
    if schedule == "jacobi":
        loaded = jacobi.explicit(loaded, {i.name: read_fmu(i.fmu, i.name) for i in loaded.instances}, jacobi=True)
    return path, loaded


def plant_states(fmus: Path) -> list[str]:
    """The plant's 20 state outputs (positions, angles and their rates), by name."""
    md = read_fmu(fmus / "TiltloadPlant.fmu", "plant")
    return [v.name for v in md.modelVariables if v.causality == "output" and v.type == "Real"][:20]


def state_of(run: Timed, fmus: Path, names: list[str]) -> np.ndarray:
    md = read_fmu(fmus / "TiltloadPlant.fmu", "plant")
    outputs = [v.name for v in md.modelVariables if v.causality == "output" and v.type == "Real"]
    return run.outputs["plant"][[outputs.index(n) for n in names]]


def measure(fmus: Path, scenario: str, stop: float, repeat: int, folder: Path, others: bool) -> dict:
    system = default_system(fmus, scenario, 1, "mixed")
    names = plant_states(fmus)
    log = folder / f"{scenario}.mcap"
    out: dict = {"log": [], "nolog": [], "jacobi": [], "libcosim": [], "ordered": [], "container": []}
    if others:
        jacobi_path, jacobi_system = package(fmus, scenario, "jacobi", folder, stop)
        ordered_path, ordered_system = package(fmus, scenario, "ordered", folder, stop)
        container = fmu_container.build(ordered_path, ordered_system, {"plant": names}, TICK)
    for _ in range(repeat):  # in turn: a change of the machine's load hits every master alike
        out["log"].append(timed(system, stop, [McapLogger(log, derived=scene_channels("plant")), loop_metrics()]))
        out["nolog"].append(timed(system, stop, [loop_metrics()]))
        if not others:
            continue
        ticks = out["nolog"][-1].ticks
        out["jacobi"].append(timed(jacobi_system, stop, [], profile=False))  # as a user's run: no clock read a step
        if libcosim_master.available():
            lc = libcosim_master.run(jacobi_path, ticks, TICK, "plant", names)
            if lc is not None:
                out["libcosim"].append(lc)
        out["ordered"].append(timed(ordered_system, stop, [], profile=False))
        out["container"].append(fmu_container.run(container, ticks, TICK, [f"plant_{n}" for n in names]))
    result = {k: best(v) if v else None for k, v in out.items()}
    result["log_bytes"] = log.stat().st_size
    if others:
        result["jacobi_state"] = state_of(result["jacobi"], fmus, names)
        result["ordered_state"] = state_of(result["ordered"], fmus, names)
    return result


def _met(value: float, target: float, at_most: bool = False) -> str:
    return "met" if (value <= target if at_most else value >= target) else "NOT met"


def _us(seconds: float, ticks: int) -> float:
    return seconds / ticks * 1e6


def _versus(label: str, theirs, ours: Timed, ticks: int, target: str) -> str:
    """Their time per tick against ours, in wall time (the target's measure) and in CPU time (what a loaded machine
    does not inflate)."""
    return (f"{label} {_us(theirs.wall, ticks):7.1f} us/tick (CPU {_us(theirs.cpu, ticks):.1f}), ours {ours.us_per_tick():7.1f} "
            f"(CPU {ours.us_per_tick(ours.cpu):.1f}), no observer: ratio {theirs.wall / ours.wall:.2f} ({target}; "
            f"CPU {theirs.cpu / ours.cpu:.2f})")


def report(scenario: str, r: dict, stop: float) -> list[str]:
    log, nolog = r["log"], r["nolog"]
    ticks = nolog.ticks
    c_cost = nolog.us_per_tick(nolog.fmi_total)
    lines = [f"{scenario.upper()} ({ticks} ticks)",
             f"  ours, full log  {log.us_per_tick():7.1f} us/tick  {stop / log.wall:6.0f}x RT  (CPU {log.us_per_tick(log.cpu):.1f} "
             f"us/tick; log {r['log_bytes'] / 1e6 / stop:.3f} MB per simulated s)",
             f"  ours, no log    {nolog.us_per_tick():7.1f} us/tick  {stop / nolog.wall:6.0f}x RT  "
             f"(CPU {nolog.us_per_tick(nolog.cpu):.1f})",
             f"  FMUs' C cost    {c_cost:7.1f} us/tick  ("
             + ", ".join(f"{n} {nolog.us_per_tick(s):.1f}" for n, s in nolog.fmi.items()) + ")",
             f"  no log / C cost {nolog.wall / nolog.fmi_total:7.3f}  (target <= {TARGETS['nolog']}: "
             f"{_met(nolog.wall / nolog.fmi_total, TARGETS['nolog'], True)})",
             f"  full log / C    {log.wall / nolog.fmi_total:7.3f}  (target <= {TARGETS['log']}: "
             f"{_met(log.wall / nolog.fmi_total, TARGETS['log'], True)}; against its own run's C cost, "
             f"{log.us_per_tick(log.fmi_total):.1f} us/tick: {log.wall / log.fmi_total:.3f})"]
    jac, lc = r["jacobi"], r["libcosim"]
    if jac is None:
        return lines
    if lc is not None:
        ratio = lc.wall / jac.wall
        target = f"target >= {TARGETS['libcosim']:g}: {_met(ratio, TARGETS['libcosim'])}" if scenario != "zse" else "stated"
        gap = np.abs(lc.outputs[:3] - r["jacobi_state"][:3]).max()
        lines.append("  Jacobi package: " + _versus("libcosim", lc, jac, ticks, target) + f"; plants end {gap:.1e} m apart")
    else:
        lines.append(f"  Jacobi package: ours {jac.us_per_tick():7.1f} us/tick; libcosim not installed or failed")
    ct, ordered = r["container"], r["ordered"]
    ratio = ct.wall / ordered.wall
    same = ("bit for bit equal" if np.array_equal(ct.outputs, r["ordered_state"])
            else f"differ by up to {np.abs(ct.outputs - r['ordered_state']).max():.2e}")
    lines.append("  ordered package: " + _versus("container", ct, ordered, ticks,
                                                 f"target >= {TARGETS['container']:g}: {_met(ratio, TARGETS['container'])}")
                 + f"; the plants' 20 states {same}")
    return lines


def before_folder(commit: str, fmus: Path, tmp: Path) -> Path:
    """This tree's FMUs with the plant and controller of commit (built from its code) in their place."""
    from fmu_arithmetic import FMUS, REPO, build_tree

    tree = tmp / "tree-before"
    tree.mkdir()
    archive = subprocess.run(["git", "-C", str(REPO), "archive", commit], check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(tree)], input=archive, check=True)
    built = tmp / "built-before"
    build_tree(tree, built, tmp / "cache-before")
    folder = tmp / "fmus-before"
    shutil.copytree(fmus, folder)
    for name in FMUS.values():
        shutil.copy2(built / name, folder / name)
    return folder


def before_after(commit: str, folders: dict[str, Path], scenario: str, stop: float, repeat: int) -> list[str]:
    """The no-log loop on the commit's plant and controller and on this tree's, in turn; best of repeat each."""
    runs: dict[str, list[Timed]] = {k: [] for k in folders}
    for _ in range(repeat):
        for k, folder in folders.items():
            runs[k].append(timed(default_system(folder, scenario, 1, "mixed"), stop, [loop_metrics()]))
    b, a = best(runs["before"]), best(runs["after"])
    pa, pb = a.outputs["plant"], b.outputs["plant"]
    same = ("bit for bit equal" if np.array_equal(pa, pb) else "not comparable (other outputs)" if pa.shape != pb.shape
            else f"differ by up to {np.abs(pa - pb).max():.2e}")
    return [f"{scenario.upper()} before {commit} / after (this tree), no log, {b.ticks} ticks:",
            f"  x RT        {stop / b.wall:8.0f}  {stop / a.wall:8.0f}   after/before time {a.wall / b.wall:.2f}",
            f"  C cost/tick {b.us_per_tick(b.fmi_total):6.1f} us {a.us_per_tick(a.fmi_total):6.1f} us   "
            f"{a.fmi_total / b.fmi_total:.2f}  (" + ", ".join(f"{n} {b.us_per_tick(b.fmi[n]):.1f} -> {a.us_per_tick(s):.1f}"
                                                          for n, s in a.fmi.items()) + ")",
            f"  the plants' outputs at the end: {same}"]


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    p.add_argument("--stop", type=float, default=20.0, help="s of trajectory 1 per run (default 20)")
    p.add_argument("--repeat", type=int, default=3, help="runs of each master per scenario, the best kept (default 3)")
    p.add_argument("--quick", action="store_true", help="5 s runs, once each: shows the script works, figures are rough")
    p.add_argument("--scenarios", nargs="+", choices=SCENARIOS, default=list(SCENARIOS))
    p.add_argument("--ours-only", action="store_true", help="no libcosim and no container")
    p.add_argument("--before", metavar="COMMIT", help="only the before/after comparison with this commit's plant and "
                   "controller FMUs (issue 41; e.g. b93cc50)")
    args = p.parse_args()
    if args.stop <= 0 or args.repeat < 1:
        p.error("--stop must be > 0 and --repeat >= 1")
    stop, repeat = (5.0, 1) if args.quick else (args.stop, args.repeat)
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    fmus = Path("fmus")
    build_all(fmus, progress=lambda _: None)
    print(f"{machine()}\n{stop:g} s of trajectory 1 per run, mixed H2/Hinf design, best of {repeat}\n")
    with tempfile.TemporaryDirectory() as tmp:
        if args.before:
            folders = {"before": before_folder(args.before, fmus, Path(tmp)), "after": fmus}
            for scenario in args.scenarios:
                print("\n".join(before_after(args.before, folders, scenario, stop, repeat)), flush=True)
            print(f"\nload average at the end: {', '.join(f'{x:.1f}' for x in os.getloadavg())} (on {os.cpu_count()} cores)")
            return
        for scenario in args.scenarios:
            folder = Path(tmp) / scenario
            folder.mkdir()
            r = measure(fmus, scenario, stop, repeat, folder, not args.ours_only)
            print("\n".join(report(scenario, r, stop)), flush=True)
    print(f"\nload average at the end: {', '.join(f'{x:.1f}' for x in os.getloadavg())} (on {os.cpu_count()} cores)")


if __name__ == "__main__":
    main()

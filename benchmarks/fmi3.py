"""The loop on FMI 2.0, plain FMI 3.0 and clocked FMI 3.0 FMUs, side by side: wall time, the master's share, same bits.

Each set runs the ZSE scenario (trajectory 1, mixed design) without a log, several rounds interleaved so the
machine's load touches every set alike; printed: the best wall time, and the microseconds of CPU time per tick (the
loop's thread: other processes' load does not inflate it) spent in the FMUs' FMI calls and outside them (the
master's own work), each the least of the rounds; the path the C tick loop takes for each FMU, and whether
the metrics are the same bits as FMI 2.0's. The clocked set runs Event Mode at every tick for the sensors and the
controller (fmi3EnterEventMode, fmi3SetClock, clocked gets, fmi3UpdateDiscreteStates, fmi3EnterStepMode besides
the step), in the kernel; the same set once more with its clocked FMUs stepped through the Python callback (the path
a hosted FMU takes) shows what the kernel saves. The Scheduled Execution controller (TiltloadControllerSE) in place of
the clocked one, with the clocked sensors: the kernel as the scheduler of its partitions, the same through the Python
callback (fmi3_scheduled.py's path), and the kernel path once more with no lock callbacks given to the FMU (no-ops
then): the difference of the FMI columns is what the Python lock callbacks cost. Then the twelve reproduction cases
(ch. 5, seed 1, full length) on the three sets and the SE controller on both its paths: the same bits.

Run: python benchmarks/fmi3.py [stop] [rounds] [--fmus FOLDER] [--no-cases]
     (FMUs built into FOLDER, by default a temporary one; exit 1 if any metrics differ)
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import tempfile
import time
import types
from pathlib import Path

from tiltload.master.app.loop.fmus import build_all, build_many, fmu_folder, scheduled_recipes
from tiltload.master.app.loop.thesis import default_stop, default_system, loop_metrics
from tiltload.master.app.regression.reproduce import CASES, SEED, case_name
from tiltload.master.engine import execution
from tiltload.master.engine.execution import Execution
from tiltload.master.engine.fmi import fmi3, fmi3_scheduled
from tiltload.master.engine.native.codes import Profile
from tiltload.master.engine.native.loop import NativeLoop

CLOCKED = frozenset({"sensors", "controller"})


def timed(system, stop: float, by_callback=frozenset(), locks: bool = True) -> tuple[float, float, dict, dict]:
    metrics = loop_metrics()
    ex = Execution(system, [metrics], profile=True)
    fmi3_scheduled.Fmu3ScheduledSlave.count_locks = locks  # read when the SE FMU is instantiated
    try:
        ex.instantiate()
    finally:
        fmi3_scheduled.Fmu3ScheduledSlave.count_locks = True
    if by_callback:  # the same instances, their clocked FMUs stepped through the Python callback
        ex.loop = NativeLoop(ex, by_callback=by_callback)
    ex.loop.plan.profile = Profile.CPU  # the kernel times the FMUs' calls in this thread's CPU time (tl_codes.h)
    paths = dict(ex.loop.paths)
    for inst in ex.instances.values():
        inst.fmi_seconds = 0.0
    t0, cpu0 = time.perf_counter(), time.thread_time()
    ex.run(stop)
    wall, cpu = time.perf_counter() - t0, time.thread_time() - cpu0
    fmi = sum(inst.fmi_seconds for inst in ex.instances.values())
    locks = getattr(ex.instances["controller"], "locks", 0)
    ex.close()
    return wall, fmi, cpu - fmi, metrics.table(), paths, locks


def se_system(folder: Path, *case, **kw):
    """The clocked loop with the Scheduled Execution controller in place of the clocked one."""
    system = default_system(folder, *case, fmi=3, clocked=True, **kw)
    system.instance("controller").fmu = folder / "TiltloadControllerSE.fmu"
    return system


def case_metrics(folder: Path, case, scheduled=None, **kw) -> dict:
    scenario, trajectory, controller = case
    metrics = loop_metrics()
    system = (se_system(folder, scenario, trajectory, controller, SEED) if scheduled else
              default_system(folder, scenario, trajectory, controller, SEED, **kw))
    ex = Execution(system, [metrics])
    ex.instantiate()
    if scheduled == "callback":
        ex.loop = NativeLoop(ex, by_callback={"controller"})
    try:
        ex.run(default_stop(trajectory))
    finally:
        ex.close()
    return metrics.table()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    parser.add_argument("stop", nargs="?", type=float, default=40.0)
    parser.add_argument("rounds", nargs="?", type=int, default=3)
    parser.add_argument("--fmus", type=Path, help="build into (and reuse) this folder")
    parser.add_argument("--no-cases", action="store_true", help="skip the twelve reproduction cases")
    args = parser.parse_args()
    # the callback path's own timers (the slave's FMI calls, the execution's sets) in this thread's CPU time too
    execution.time = fmi3.time = fmi3_scheduled.time = types.SimpleNamespace(perf_counter=time.thread_time)
    with tempfile.TemporaryDirectory() as tmp:
        base = args.fmus or Path(tmp) / "fmus"
        say = lambda m: print(f"  {m}", file=sys.stderr)  # noqa: E731
        build_all(base, progress=say)
        build_all(fmu_folder(base, 3), progress=say, fmi_version=3)
        build_all(fmu_folder(base, 3), progress=say, fmi_version=3, clocked=True)
        build_many(scheduled_recipes(("load",)), fmu_folder(base, 3), progress=say, fmi_version=3)
        three = fmu_folder(base, 3)
        sets = {"FMI 2.0": (default_system(base, "zse", 1, "mixed"), frozenset()),
                "FMI 3.0 plain": (default_system(three, "zse", 1, "mixed", fmi=3), frozenset()),
                "FMI 3.0 clocks": (default_system(three, "zse", 1, "mixed", fmi=3, clocked=True), frozenset()),
                "clocks, callback": (default_system(three, "zse", 1, "mixed", fmi=3, clocked=True), CLOCKED),
                "SE": (se_system(three, "zse", 1, "mixed"), frozenset()),
                "SE, callback": (se_system(three, "zse", 1, "mixed"), frozenset({"controller"})),
                "SE, no locks": (se_system(three, "zse", 1, "mixed"), frozenset())}
        best: dict[str, list] = {}  # the least wall time, FMUs' and master's CPU time of the rounds; metrics; paths
        for _ in range(args.rounds):
            for label, (system, by_callback) in sets.items():
                r = timed(system, args.stop, by_callback, locks=label != "SE, no locks")
                best[label] = [min(a, b) for a, b in zip(best[label][:3], r[:3])] + list(r[3:]) if label in best else list(r)
        stop, ticks = args.stop, round(args.stop / 0.012)
        print(f"machine: {platform.node()} {platform.machine()} {platform.processor() or ''} ({sys.version.split()[0]}, "
              f"{os.cpu_count()} cores, load {os.getloadavg()[0]:.2f}); {stop:g} s = {ticks} ticks, best of {args.rounds}")
        print(f"{'FMU set':>16} {'wall s':>8} {'x real time':>12} {'FMI us/tick':>12} {'master us/tick':>15}  metrics"
              f"    sensors, controller")
        reference = best["FMI 2.0"][3]
        master = {}
        for label, (wall, fmi, own, metrics, paths, _) in best.items():
            same = "same bits" if metrics == reference else "DIFFER   "
            master[label] = own / ticks * 1e6
            print(f"{label:>16} {wall:8.2f} {stop / wall:12.0f} {fmi / ticks * 1e6:12.1f} {master[label]:15.1f}  {same}"
                  f"  {paths['sensors']}; {paths['controller']}")
        gap = master["FMI 3.0 clocks"] - master["FMI 3.0 plain"]
        print(f"master share, clocked in the kernel minus plain: {gap:+.1f} us/tick (target: within 2 us); "
              f"through the callback: {master['clocks, callback'] - master['FMI 3.0 plain']:+.1f} us/tick")
        print(f"master share, Scheduled Execution in the kernel minus clocked in the kernel: "
              f"{master['SE'] - master['FMI 3.0 clocks']:+.1f} us/tick; SE through the callback minus SE in the kernel: "
              f"{master['SE, callback'] - master['SE']:+.1f} us/tick")
        pairs = best["SE"][5] / ticks
        locks_us = (best["SE"][1] - best["SE, no locks"][1]) / ticks * 1e6
        print(f"the SE FMU's Python lock callbacks: {pairs:.1f} lock/unlock pairs a tick, {locks_us:.1f} us/tick of the "
              f"FMI column ({locks_us / max(pairs, 1e-9) / 2 * 1e3:.0f} ns a callback)")
        ok = all(r[3] == reference for r in best.values())
        if not args.no_cases:
            print("the twelve reproduction cases (seed 1, full length), metrics against FMI 2.0's:")
            for case in CASES:
                two = case_metrics(base, case)
                plain = case_metrics(three, case, fmi=3)
                clocked = case_metrics(three, case, fmi=3, clocked=True)
                se = case_metrics(three, case, scheduled="kernel")
                se_callback = case_metrics(three, case, scheduled="callback")
                verdict = lambda m: "same bits" if m == two else "DIFFER"  # noqa: E731
                print(f"  {case_name(*case):>18}: plain FMI 3.0 {verdict(plain)}, clocked FMI 3.0 {verdict(clocked)}, "
                      f"SE in the kernel {verdict(se)}, SE through the callback {verdict(se_callback)}")
                ok = ok and plain == two == clocked == se == se_callback
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())

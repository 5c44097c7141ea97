"""`tiltload run --profile` against an independent measurement: each of the thesis loop's FMUs (all four in this
process) timed by the loop's profile, and the same FMU's step timed alone by a small C harness
(benchmarks/c/step_alone.c: the FMU loaded by itself in this process, with the loop's parameters; its doStep and
getReal of its outputs timed in a C loop of their own with CLOCK_MONOTONIC, none of the tick loop's code on the way),
median and p99 side by side. The harness leaves an FMU's inputs at their start values and keeps its caches to itself;
the loop's FMUs share theirs with three others: the loop's figures are expected a little above the harness's.

Run: python benchmarks/profile_agreement.py [--scenario fsi] [--stop 20] [--steps 5000]
"""

from __future__ import annotations

import argparse
import ctypes
import os
import platform
import sys
import tempfile
from pathlib import Path

import numpy as np
from tiltload.master.app.loop.fmus import build_all
from tiltload.master.app.loop.thesis import default_system, loop_metrics
from tiltload.master.engine.execution import Execution
from tiltload.master.engine.fmi.in_process import load
from tiltload.master.engine.fmi.model_description import read_fmu
from tiltload.master.engine.native import kernel
from tiltload.master.engine.profile import Profiler

HARNESS = Path(__file__).resolve().parent / "c" / "step_alone.c"
BATCH = 500  # steps from one initialization (6 s: the plant, its inputs at their start values, falls all along)


def harness() -> ctypes.CDLL:
    lib = kernel.compiled("step_alone", (HARNESS,))
    lib.step_alone.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_double, ctypes.c_double,
                               ctypes.c_int, ctypes.c_void_p, ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p]
    return lib


def alone(lib, spec, tick: float, steps: int) -> np.ndarray:
    """The FMU of instance spec loaded by itself in this process (FMPy), with the loop's parameters, its steps timed by
    the harness (ns each) in batches of BATCH from a reset, the first tenth of each left out (caches warming)."""
    slave = load(spec.name, Path(spec.fmu), read_fmu(Path(spec.fmu), spec.name))
    try:
        outputs = slave.out_vrs["Real"]
        vrs = (ctypes.c_uint * max(len(outputs), 1))(*outputs)
        out = (ctypes.c_double * max(len(outputs), 1))()
        times = []
        for first in range(0, steps, BATCH):
            slave.initialize(dict(spec.parameters))
            n = min(BATCH, steps - first)
            ns = (ctypes.c_int64 * n)()
            done = lib.step_alone(slave.component, slave.function_pointer("fmi2DoStep"),
                                  slave.function_pointer("fmi2GetReal"), 0.0, tick, n, vrs, len(outputs), out, ns)
            if done < n:
                raise SystemExit(f"{spec.name}: its step at t = {done * tick:g} s failed, timed alone")
            times.append(np.frombuffer(ns, dtype=np.int64)[n // 10:])
            slave.reset()
        return np.concatenate(times)
    finally:
        slave.close()


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    p.add_argument("--scenario", default="fsi", choices=("fsi", "lkf", "zse"))
    p.add_argument("--stop", type=float, default=20.0, help="the profiled run's length, s")
    p.add_argument("--steps", type=int, default=5000, help="steps timed alone per FMU")
    args = p.parse_args()
    if not (0 < args.stop <= 600 and 100 <= args.steps <= 1_000_000):
        p.error("--stop in (0, 600] s and --steps in [100, 1e6]")
    if platform.system() != "Linux":
        p.error("the harness loads Linux FMU binaries (binaries/linux64)")
    with tempfile.TemporaryDirectory(prefix="tl-profile-agreement-") as tmp:
        folder = Path(tmp)
        fmus = folder / "fmus"
        build_all(fmus)
        system = default_system(fmus, args.scenario, 0, "mixed")
        ex = Execution(system, [loop_metrics()])
        ex.instantiate()
        try:
            profiler = Profiler(ex)
            profiler.start()
            ex.run(args.stop)
            profile = profiler.stop()
        finally:
            ex.close()
        lib = harness()
        cpu = next((line.split(":", 1)[1].strip() for line in Path("/proc/cpuinfo").read_text().splitlines()
                    if line.startswith("model name")), platform.processor())
        print(f"machine: {platform.node()}: {cpu}, {os.cpu_count()} cores; load average {os.getloadavg()[0]:.2f}")
        print(f"{args.scenario}, {profile.ticks} ticks profiled in the loop; {args.steps} steps alone (the first tenth "
              "left out), µs")
        print(f"{'FMU':<12}{'loop median':>12}{'alone':>9}{'ratio':>7}{'loop p99':>11}{'alone':>9}")
        for fmu in profile.fmus:
            times = alone(lib, system.instance(fmu.name), system.tick, args.steps) * 1e-3
            median, p99 = np.median(times), np.quantile(times, 0.99)
            print(f"{fmu.name:<12}{fmu.steps.median * 1e6:>12.2f}{median:>9.2f}{fmu.steps.median * 1e6 / median:>7.2f}"
                  f"{fmu.steps.p99 * 1e6:>11.2f}{p99:>9.2f}")
        print(f"load average after: {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

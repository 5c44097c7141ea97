"""What a fault costs the tick loop: us per tick of the FSI loop (the cheapest, where a cost shows most) with one fault
active the whole run, against the same loop without faults.

Every fault here runs inside the C tick loop (value faults, noise, delay, stale, jitter, dropout). The "in Python"
cases force the fault into the Python manipulator, through the loop's hook at that one instance's side (its other
connections, and the other instances, stay in C), as the loop applies faults on unconnected inputs. Noise and jitter
draw from default_rng([seed, fault, tick]); the kernel's C makes those draws (tl_draw.c); the "numpy draws" cases
apply them in Python with numpy's Generator instead, as before the kernel could, side by side. Each fault acts on the
three camera measurements (sensors.meas_d_BL_x/y/z; dropout on the GPS pair with its flag, as
docs/faults/gps_dropout.json), from t = 0. Trajectory 1, mixed design, no log, the loop's metrics, best of --repeat
runs taken in turn (each round starting one case later); the FMU calls are not timed (as a user's run).

Run: python benchmarks/fault_cost.py [--stop 20] [--repeat 5]
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import os
from pathlib import Path

from tiltload.master.app.loop.fmus import build_all
from tiltload.master.app.loop.thesis import default_system, loop_metrics
from tiltload.master.engine.faults.apply import Manipulator
from tiltload.master.engine.faults.parse import parse
from tiltload.master.engine.native import kernel
from timing import best, machine, timed

CAMERA = ["sensors.meas_d_BL_x", "sensors.meas_d_BL_y", "sensors.meas_d_BL_z"]
FAULTS = {
    "bias (C)": {"action": "bias", "targets": CAMERA, "value": 0.01},
    "scale (C)": {"action": "scale", "targets": ["plant.f_R"], "value": 0.7},
    "hold (C)": {"action": "hold", "targets": CAMERA},
    "noise (C)": {"action": "noise", "targets": CAMERA, "value": 0.01, "seed": 1},
    "noise (numpy draws)": {"action": "noise", "targets": CAMERA, "value": 0.01, "seed": 1},
    "stale (C)": {"action": "stale", "targets": CAMERA, "value": 3},
    "delay (C)": {"action": "delay", "targets": CAMERA, "value": 2},
    "delay (in Python)": {"action": "delay", "targets": CAMERA, "value": 2},
    "jitter (C)": {"action": "jitter", "targets": CAMERA, "value": 3, "seed": 1},
    "jitter (numpy draws)": {"action": "jitter", "targets": CAMERA, "value": 3, "seed": 1},
    "dropout (C)": {"action": "dropout", "targets": ["sensors.meas_x_B", "sensors.meas_y_B"], "flag": "sensors.gps_new"},
    "dropout (in Python)": {"action": "dropout", "targets": ["sensors.meas_x_B", "sensors.meas_y_B"], "flag": "sensors.gps_new"},
}


@contextlib.contextmanager
def in_python():
    """The fault applied by the Python manipulator through the loop's hook, as before the kernel could."""
    saved = Manipulator.native_capable
    Manipulator.native_capable = lambda self, k, draws=False: False
    try:
        yield
    finally:
        Manipulator.native_capable = saved


@contextlib.contextmanager
def numpy_draws():
    """Noise and jitter drawn by numpy's Generator in Python (the reference the C draws are tested against)."""
    saved = kernel.draws_in_c
    kernel.draws_in_c = lambda: False
    try:
        yield
    finally:
        kernel.draws_in_c = saved


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    p.add_argument("--stop", type=float, default=20.0, help="s of trajectory 1 per run (default 20)")
    p.add_argument("--repeat", type=int, default=5, help="runs of each case, the best kept (default 5)")
    args = p.parse_args()
    fmus = Path(__file__).parent / "fmus"
    build_all(fmus)
    base = default_system(fmus, "fsi", 1, "mixed")
    cases = {"no fault": base}
    for name, fault in FAULTS.items():
        cases[name] = dataclasses.replace(base, faults=parse([{"name": name, "start": 0.0, **fault}]))
    print(machine())
    print(f"FSI loop, {args.stop:g} s of trajectory 1, no log, best of {args.repeat}")
    runs: dict[str, list] = {name: [] for name in cases}
    names = list(cases)
    for r in range(args.repeat):  # in turn, each round starting one case later: no case always runs first
        for name in names[r % len(names):] + names[:r % len(names)]:
            forced = numpy_draws() if "numpy" in name else in_python() if "in Python" in name else contextlib.nullcontext()
            with forced:
                runs[name].append(timed(cases[name], args.stop, [loop_metrics()], profile=False))
    reference = best(runs["no fault"]).us_per_tick()
    for name in cases:
        us = best(runs[name]).us_per_tick()
        print(f"  {name:<21} {us:6.1f} us/tick  ({us - reference:+5.1f} us, x{us / reference:.2f})")
    print("load average at the end: " + ", ".join(f"{x:.1f}" for x in os.getloadavg()))


if __name__ == "__main__":
    main()

"""Timing one run of a system in tiltload's master: the wall time of the stepping and each FMU's share of it."""

from __future__ import annotations

import time

from tiltload.master.engine.execution import Execution


def timed_run(system, stop: float, observers=()) -> tuple[float, dict[str, float]]:
    """(wall seconds of ex.run(stop), {instance: seconds in its FMI calls}); instantiation is not timed."""
    ex = Execution(system, list(observers))
    try:
        ex.instantiate()
        for inst in ex.instances.values():
            inst.fmi_seconds = 0.0
        t0 = time.perf_counter()
        ex.run(stop)
        wall = time.perf_counter() - t0
        return wall, {n: i.fmi_seconds for n, i in ex.instances.items()}
    finally:
        ex.close()

"""Timing one run of a system in tiltload's master: the wall time of the stepping and each FMU's share of it."""

from __future__ import annotations

import os
import platform
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from tiltload.master.engine.execution import Execution


@dataclass
class Timed:
    """One run: wall seconds of ex.run(stop) and ex.finish() (a log's last chunks and summary written), {instance: seconds
    in its FMI calls}, ticks run, the Real outputs every instance held at the end, and the process's CPU seconds over
    the same span (all threads: the log's writer too; what other work on a shared machine does not inflate)."""

    wall: float
    fmi: dict[str, float]
    ticks: int
    outputs: dict[str, np.ndarray]
    cpu: float

    def us_per_tick(self, seconds: float | None = None) -> float:
        return (self.wall if seconds is None else seconds) / self.ticks * 1e6

    @property
    def fmi_total(self) -> float:
        return sum(self.fmi.values())


def timed(system, stop: float, observers=(), profile: bool = True) -> Timed:
    """Run the system to stop and finish its observers (a log's last chunks and summary written); instantiation and
    freeing the instances are not timed. fmi_seconds is what the C tick loop measured around each instance's set, doStep and get calls
    (profile; without it, as a user's run, the loop reads no clock and fmi_seconds stay 0)."""
    ex = Execution(system, list(observers), profile=profile)
    try:
        ex.instantiate()
        for inst in ex.instances.values():
            inst.fmi_seconds = 0.0
        c0, t0 = time.process_time(), time.perf_counter()
        ex.run(stop)
        fmi = {n: i.fmi_seconds for n, i in ex.instances.items()}
        outputs = {n: i.values["Real"].copy() for n, i in ex.instances.items()}
        ticks = ex.ticks_done
        ex.finish()
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        return Timed(wall, fmi, ticks, outputs, cpu)
    finally:
        ex.close()


def best(runs: list):
    """The run of least wall time (anything with a .wall): on a shared machine, the one least disturbed by other work."""
    return min(runs, key=lambda r: r.wall)


def timed_run(system, stop: float, observers=()) -> tuple[float, dict[str, float]]:
    """(wall seconds of ex.run(stop), {instance: seconds in its FMI calls}); instantiation is not timed."""
    run = timed(system, stop, observers)
    return run.wall, run.fmi


def machine() -> str:
    """The machine and how busy it is: the figures mean little without it."""
    cpuinfo = Path("/proc/cpuinfo")
    cpu = platform.processor()
    if cpuinfo.exists():
        cpu = next((line.split(":", 1)[1].strip() for line in cpuinfo.read_text().splitlines()
                    if line.startswith("model name")), cpu)
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    return f"{platform.node()}: {os.cpu_count()} cores ({cpu}), Python {platform.python_version()}, load average {load}"

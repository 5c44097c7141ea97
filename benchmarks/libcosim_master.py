"""The same package in libcosim (libcosimpy, same process): a fixed-step Jacobi master, observed by a last-value
observer only."""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np


@dataclass
class LibcosimRun:
    wall: float  # seconds in simulate_until
    cpu: float  # the process's CPU seconds in it, all its threads
    outputs: np.ndarray  # the asked-for Real outputs of one instance at the end


def available() -> bool:
    try:
        import libcosimpy  # noqa: F401
    except ImportError:
        return False
    return True


def run(package: Path, ticks: int, tick: float, instance: str, outputs: list[str]) -> LibcosimRun | None:
    """Run the package for ticks ticks of tick seconds (libcosim counts whole nanoseconds); None if it fails."""
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver

    log_output_level(CosimLogLevel.ERROR)
    ex = CosimExecution.from_ssp_file(str(package))
    observer = CosimObserver.create_last_value()
    ex.add_observer(observer)
    c0, t0 = time.process_time(), time.perf_counter()
    ok = ex.simulate_until(ticks * round(tick * 1e9))
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    if not ok:
        return None
    index = {s.name.decode(): s.index for s in ex.slave_infos()}[instance]
    refs = {v.name.decode(): v.reference for v in ex.slave_variables(index)}
    return LibcosimRun(wall, cpu, np.array(observer.last_real_values(index, [refs[n] for n in outputs])))

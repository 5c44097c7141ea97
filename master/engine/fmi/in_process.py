"""The slave of an FMU loaded into this process, whichever FMI version it is: the one place that picks the binding.

The execution (for a trusted FMU) and an FMU's host (isolation/worker.py, in its own process or under
`tiltload serve`) both call `load`, so an FMI 2.0 and an FMI 3.0 FMU (plain or with clocks) are hosted by the
same code: what differs is fmi2.py's binding or fmi3.py's, both behind the Slave interface (slave.py).
"""

from __future__ import annotations

from pathlib import Path

from .model_description import fmi_version, is_scheduled
from .slave import Slave


def load(name: str, path: Path, md, tick: float | None = None) -> Slave:
    """The FMU at path (model description md) instantiated here as name; tick: the execution's, which places the clock
    ticks of an FMI 3.0 FMU with clocks (unused otherwise)."""
    if is_scheduled(md):
        from .fmi3_scheduled import Fmu3ScheduledSlave

        return Fmu3ScheduledSlave(name, path, md, tick)
    if fmi_version(md) == 3:
        from .fmi3 import Fmu3Slave

        return Fmu3Slave(name, path, md, tick)
    from .fmi2 import InProcessFmu

    return InProcessFmu(name, path, md)

"""How the tick loop steps each instance (NativeLoop.paths): the kernel's own FMI calls, or the Python callback and
why."""

from __future__ import annotations

from ..fmi.fmi2 import InProcessFmu
from ..fmi.fmi3 import Fmu3Slave


def kernel_calls_fmi3(slave) -> bool:
    """An FMI 3.0 FMU in this process whose variables are of the kernel's types: the kernel calls its fmi3 functions
    itself (with clocks, its Event Mode too; a Scheduled Execution one's partitions, fmi3_scheduled.py's sequence)."""
    return isinstance(slave, Fmu3Slave) and slave.kernel_types


def path_of(slave) -> str:
    """How the loop steps this slave (NativeLoop.paths): the kernel's own calls, or the callback and why."""
    if isinstance(slave, Fmu3Slave) and not slave.kernel_types:
        return "callback: FMI 3.0 types the kernel does not convert"
    if kernel_calls_fmi3(slave):
        if getattr(slave, "scheduled", False):
            return "kernel: FMI 3.0 Scheduled Execution"
        return "kernel: FMI 3.0 with clocks" if slave.clocked else "kernel: FMI 3.0"
    if isinstance(slave, InProcessFmu):
        return "kernel: FMI 2.0"
    host = getattr(slave, "host", None)  # isolation.process.IsolatedFmu: a worker process, or a remote host's `where`
    if host is not None:
        return f"callback: {getattr(host, 'where', 'worker process')}"
    return f"callback: {type(slave).__name__}"

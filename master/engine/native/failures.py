"""What a failed call of the tick loop says: the kernel's error record (its kind, instance, group, status and time)
as the exception the engine raises, worded as the Python paths word the same failure."""

from __future__ import annotations

from ..errors import ExecutionError
from ..fmi.fmi3 import FMI3_NAME, MAX_EVENT_ITERATIONS
from ..fmi.model_description import fmi_version
from .codes import ErrorKind, type_name

_EVENT_CALLS = {ErrorKind.ENTER_EVENT_MODE: "enterEventMode", ErrorKind.SET_CLOCK: "setClock",
                ErrorKind.UPDATE_DISCRETE_STATES: "updateDiscreteStates", ErrorKind.ENTER_STEP_MODE: "enterStepMode"}
# a Scheduled Execution FMU's failures, worded as fmi3_scheduled.py's
_SCHEDULED = (ErrorKind.SET, ErrorKind.GET, ErrorKind.GET_CLOCKED, ErrorKind.ACTIVATE, ErrorKind.LOCKS_HELD)


def kernel_error(loop) -> BaseException:
    """The exception of the loop's last failed call (NativeLoop.plan's error record)."""
    p = loop.plan
    kind = ErrorKind(p.error_kind)
    if kind in (ErrorKind.STEP_CALLBACK, ErrorKind.HOOK_CALLBACK):
        err, loop._pending = loop._pending, None
        return err if err is not None else RuntimeError("a callback of the tick loop failed")
    slave, t = loop.slaves[p.error_instance], p.error_time
    name = (lambda typ: FMI3_NAME[typ]) if fmi_version(slave.md) == 3 else (lambda typ: typ)  # in process or not
    if getattr(slave, "scheduled", False) and kind in _SCHEDULED:
        return _scheduled_error(loop, slave, kind, t)
    if kind == ErrorKind.LINK:
        return slave.link_failed(p.error_status, p.error_group, t)
    if kind == ErrorKind.DO_STEP:
        return slave.failed(f"doStep at t={t:.6g} s", p.error_status)
    if kind == ErrorKind.TERMINATED_IN_STEP and fmi_version(slave.md) == 2:  # over the shared-memory link: fmi2Discard
        return slave.failed(f"doStep at t={t:.6g} s", p.error_status)  # with fmi2Terminated, as in process
    if kind == ErrorKind.TERMINATED_IN_STEP:  # System.fmu_end "error"
        h = loop.ex.every[loop.names[p.error_instance]] * loop.ex.system.tick
        return ExecutionError(f"{slave.name}: the FMU asked to terminate the simulation at t={t + h:.6g} s")
    if kind == ErrorKind.SET:
        group = loop.ex.groups[loop.names[p.error_instance]][p.error_group]
        return slave.failed(f"set{name(group.type)} from {group.source} at t={t:.6g} s", p.error_status)
    if kind in _EVENT_CALLS:
        return slave.failed(f"{_EVENT_CALLS[kind]} at t={t:.6g} s", p.error_status)
    if kind == ErrorKind.TERMINATED_IN_EVENT:
        return ExecutionError(f"{slave.name}: the FMU asked to terminate the simulation at t={t:.6g} s")
    if kind == ErrorKind.UNSETTLED:
        return ExecutionError(f"{slave.name}: its discrete states still needed an update after {MAX_EVENT_ITERATIONS} "
                              f"iterations at t={t:.6g} s")
    if kind == ErrorKind.GET_CLOCKED:
        clock = slave.clocks[p.error_group].name
        return slave.failed(f"get{name(type_name(p.error_type))} of {clock}'s outputs at t={t:.6g} s", p.error_status)
    return slave.failed(f"get{name(type_name(p.error_type))}", p.error_status)

def _scheduled_error(loop, slave, kind: ErrorKind, t: float) -> BaseException:
    p = loop.plan
    if kind == ErrorKind.SET:
        group = loop.ex.groups[loop.names[p.error_instance]][p.error_group]
        return slave.failed(f"set{FMI3_NAME[group.type]} at t={t:.6g} s", p.error_status)
    if kind == ErrorKind.GET:
        return slave.failed("get", p.error_status)
    if kind == ErrorKind.GET_CLOCKED:
        return slave.failed(f"get clocked outputs at t={t:.6g} s", p.error_status)
    clock = slave.clocks[p.error_group].name
    if kind == ErrorKind.ACTIVATE:
        return slave.failed(f"activateModelPartition({clock}) at t={t:.6g} s", p.error_status)
    return ExecutionError(f"{slave.name}: partition {clock} returned at t={t:.6g} s with {p.error_status} preemption "
                          "lock(s) held")

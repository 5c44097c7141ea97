"""An FMU with clocks on its host's side of the shared-memory link: a plan of the kernel (native/tl_loop.h) holding
this one FMU, which the host's C loop (c/tl_host.c) steps with the kernel's own sequence (tl_loop.c's tl_step_alone):
a clocked FMU's Event Mode, a Scheduled Execution FMU's partitions, call for call as the tick loop steps them in the
master's process (native/clocks.py plans both). The plan's groups are the link's (the master's connection groups into
the FMU, in its order); the clocked outputs are held in the slave's own buffers, so a state the worker takes on its
pipe holds what the kernel read, and the state between steps (an Event Mode pending, an event asked for, the next
event time) goes from the slave into the plan when the host takes the link and back when it leaves it.
"""

from __future__ import annotations

import ctypes

import numpy as np

from ..fmi.fmi3_inputs import FMI3_NAME
from ..fmi.slave import TYPES
from ..native import kernel
from ..native.clocks import ClockedPlan
from ..native.codes import value_type

_DTYPE = {"Real": np.float64, "Integer": np.int32, "Boolean": np.int32}  # as the plan's arrays hold them


class _Group:
    """A connection group as ClockedPlan reads it: its type, its inputs' value references, its values."""

    def __init__(self, typ: str, vrs: list[int]) -> None:
        self.type = typ
        self.dst_vrs = (ctypes.c_uint * max(len(vrs), 1))(*vrs)
        self.view = self.values = np.zeros(len(vrs), dtype=_DTYPE[typ])


class HostPlan:
    """The kernel's plan of slave (a clocked fmi3.Fmu3Slave or a Scheduled Execution one) with the link's groups
    [(type, [value references])]; the arguments tl_host.c takes from it: alone, step_alone, group_values, out."""

    def __init__(self, slave, groups: list[tuple[str, list[int]]]) -> None:
        self.slave = slave
        self.groups = [_Group(t, vrs) for t, vrs in groups]
        self.clocks = ClockedPlan(slave, self.groups, chunk=0)  # no activation is recorded: the master logs none of a host's
        fn = slave.function_pointer
        c = self.instance = (kernel.Instance * 1)()
        inst = c[0]
        inst.component, inst.every, inst.fmi3 = slave.component, 1, 1
        if not getattr(slave, "scheduled", False):  # no fmi3DoStep in Scheduled Execution
            inst.do_step3 = fn("fmi3DoStep")
        self._keep: list = []
        for typ in TYPES:
            t = value_type(typ)
            values = slave.values[typ]
            vrs = (ctypes.c_uint * max(values.size, 1))(*slave.out_vrs[typ])
            self._keep.append(vrs)
            inst.n_out[t], inst.out[t], inst.out_vrs[t] = values.size, values.ctypes.data, ctypes.addressof(vrs)
            inst.set3[t], inst.get3[t] = fn(f"fmi3Set{FMI3_NAME[typ]}"), fn(f"fmi3Get{FMI3_NAME[typ]}")
        c_groups = (kernel.Group * max(len(self.groups), 1))()
        for g, group in zip(c_groups, self.groups):
            g.type = g.source_type = value_type(group.type)
            g.n, g.dst_vrs, g.values = len(group.view), ctypes.addressof(group.dst_vrs), group.values.ctypes.data
        self.c_groups = c_groups
        inst.n_groups, inst.groups = len(self.groups), c_groups
        room = max([slave.values["Boolean"].size, *(len(g.view) for g in self.groups if g.type == "Boolean"), 1])
        self.booleans = (ctypes.c_bool * room)()
        inst.booleans = ctypes.addressof(self.booleans)
        inst.clocks = ctypes.pointer(self.clocks.c)
        self.plan = kernel.Plan(n_instances=1, instances=c, tick=slave.tick, ends_allowed=1)  # the master decides an end
        self.group_values = (ctypes.c_void_p * max(len(self.groups), 1))(*(g.values.ctypes.data for g in self.groups))
        self.out = [slave.values[typ].ctypes.data for typ in TYPES]
        self.step_alone = ctypes.cast(kernel.library().tl_step_alone, ctypes.c_void_p).value

    @property
    def alone(self) -> int:
        return ctypes.addressof(self.plan)

    def take(self) -> None:
        """Before the host's C loop: the slave's state between steps into the plan."""
        self.clocks.push()

    def leave(self) -> None:
        """After it: the plan's state back into the slave (a state taken on the pipe, a reset, a close see it)."""
        self.clocks.pull()

    def forget_inputs(self) -> None:
        """After a reset: no discrete input was set yet."""
        self.clocks.forget_inputs()

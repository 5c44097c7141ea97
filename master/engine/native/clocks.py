"""A clocked FMI 3.0 FMU stepped by the C tick loop: the plan of its Event Mode (tl_loop.h's tl_clocks), built
from its in-process slave (fmi3.Fmu3Slave), and what the two hand each other around a call of the loop.

The plan follows the slave's own sequence (fmi3.py, Fmu3Slave.do_step) call for call: its clocks' schedule
(interval and shift in ticks), its inputs split by kind within each of the execution's connection groups (continuous,
discrete, or clocked by clock j: each set only where the standard allows it), its output reads (those of no clock
after every step, each clock's at its ticks). The clocked outputs are held in the slave's own buffers, so its
initialization, snapshots and restored states see what the kernel read. The state between steps (in the Event Mode
after initialization, an event asked for, the next event time) goes into the plan before each call and back into
the slave after it, with the clock ticks the call activated. The function pointers are looked up once, here.

A Scheduled Execution slave (fmi3_scheduled.py) gets the same plan with its partitions' rank order (computed once:
a due set's order is the total order with the clocks not due left out) and fmi3ActivateModelPartition: the kernel
then activates the due partitions instead of Event Mode and fmi3DoStep, and checks after each that the slave's lock
callbacks (Python ctypes callbacks, counting into a C int the kernel reads) hold no lock.
"""

from __future__ import annotations

import ctypes

import numpy as np

from ..fmi.fmi3 import MAX_EVENT_ITERATIONS
from ..fmi.fmi3_inputs import FMI3_C
from . import kernel
from .codes import PartKind, value_type


class ClockedPlan:
    """The kernel's tl_clocks of one clocked slave; groups: the execution's connection groups into it (in the order
    the kernel gathers them), chunk: the most ticks one call runs."""

    def __init__(self, slave, groups, chunk: int) -> None:
        self.slave = slave
        self.names = [k.name for k in slave.clocks]
        self._keep: list = []
        c = self.c = kernel.Clocks(max_iterations=MAX_EVENT_ITERATIONS)
        address = slave.function_pointer
        if not getattr(slave, "scheduled", False):  # a Scheduled Execution FMU has no Event Mode (and need not export it)
            c.enter_event_mode, c.enter_step_mode = address("fmi3EnterEventMode"), address("fmi3EnterStepMode")
            c.set_clock, c.update_discrete_states = address("fmi3SetClock"), address("fmi3UpdateDiscreteStates")
        n = len(slave.schedule)
        c.n_clocks = n
        c.clock_vrs = self._array(ctypes.c_uint, [slave.clocks[j].value_reference for j, *_ in slave.schedule])
        c.interval = self._ints([every for _, _, every, _ in slave.schedule])
        c.shift = self._ints([shift for *_, shift in slave.schedule])
        c.due, c.due_vrs = self._array(ctypes.c_int, [0] * n), self._array(ctypes.c_uint, [0] * n)
        c.due_on = self._array(ctypes.c_bool, [True] * n)
        c.activation_capacity = chunk * n
        self.activation_clock = np.zeros(chunk * n, dtype=np.int32)
        self.activation_tick = np.zeros(chunk * n, dtype=np.int64)
        c.activation_clock, c.activation_tick = self.activation_clock.ctypes.data, self.activation_tick.ctypes.data
        parts = [part for g, group in enumerate(groups) for part in self._parts(g, group)]
        self.parts = (kernel.Part * max(len(parts), 1))(*parts)
        c.n_parts, c.parts = len(parts), self.parts
        # those of no clock first, then by clock (each clock's in the slave's order, so its gets come in the same order)
        by_clock = sorted(slave.output_reads(), key=lambda r: -1 if r[0] is None else r[0])
        reads = [self._read(*r) for r in by_clock]
        self.reads = (kernel.Read * max(len(reads), 1))(*reads)
        c.n_reads, c.reads = len(reads), self.reads
        clocks = [r.clock for r in reads]
        c.read_first = self._array(ctypes.c_int, [sum(k < j for k in clocks) for j in range(-1, n + 1)])
        if getattr(slave, "scheduled", False):
            c.activate = address("fmi3ActivateModelPartition")
            c.order = self._array(ctypes.c_int, slave.rank_order)
            c.lock_depth = ctypes.addressof(slave.lock_depth)

    def _array(self, ctype, values) -> int:
        array = (ctype * max(len(values), 1))(*values)
        self._keep.append(array)
        return ctypes.addressof(array)

    def _ints(self, values) -> int:
        array = np.ascontiguousarray(values, dtype=np.int64)
        self._keep.append(array)
        return array.ctypes.data

    def _parts(self, g: int, group) -> list:
        """One group's inputs by kind, in the order the kinds first appear (as fmi3.py's staging splits them)."""
        kinds: dict[int, list[int]] = {}
        for i, vr in enumerate(group.dst_vrs[:len(group.view)]):
            kind = self.slave.input_kind.get((group.type, vr), "continuous")
            code = PartKind.CONTINUOUS if kind == "continuous" else PartKind.DISCRETE if kind == "discrete" else kind
            kinds.setdefault(code, []).append(i)
        parts = []
        for code, index in kinds.items():
            m = len(index)
            parts.append(kernel.Part(group=g, kind=code, n=m, vrs=self._array(ctypes.c_uint, [group.dst_vrs[i] for i in index]),
                                     index=self._ints(index), whole=m == len(group.view),
                                     buffer=self._array(FMI3_C[group.type], [0] * m),
                                     applied=self._array(FMI3_C[group.type], [0] * m)))
        return parts

    def _read(self, clock, typ: str, vrs, n: int, buffer, idx) -> kernel.Read:
        index = np.arange(n) if isinstance(idx, slice) else idx  # buffers and vrs are the slave's, alive as long
        return kernel.Read(type=value_type(typ), clock=-1 if clock is None else clock, n=n, vrs=ctypes.addressof(vrs),
                           index=self._ints(index), whole=isinstance(idx, slice), buffer=ctypes.addressof(buffer))

    def push(self) -> None:
        """The slave's state between steps into the plan (before a call of the loop)."""
        in_event, asked, next_event = self.slave.event_state
        c = self.c
        c.in_event, c.event_asked = in_event, asked
        c.next_event_defined, c.next_event = next_event is not None, next_event if next_event is not None else 0.0

    def pull(self) -> None:
        """The plan's state back into the slave, and the clock ticks of the call into its activations."""
        c = self.c
        self.slave.event_state = (bool(c.in_event), bool(c.event_asked), c.next_event if c.next_event_defined else None)
        clock, tick = self.activation_clock[:c.activations], self.activation_tick[:c.activations]
        for j, name in enumerate(self.names):  # per clock, in tick order: a few numpy calls per call of the loop
            self.slave.activations[name].extend(tick[clock == j].tolist())

    def forget_inputs(self) -> None:
        """After a reset: no discrete input was set yet (the first step is an event anyway)."""
        for i in range(self.c.n_parts):
            self.parts[i].has_applied = 0

"""An FMI 3.0 Scheduled Execution FMU loaded into this process, behind the Slave interface: the master as the scheduler
of its model partitions (FMI 3.0, chapter 5; docs/fmi3.md, "Scheduled Execution").

It reuses the clocked co-simulation slave's staging (fmi3.py): the execution's setters stage the inputs, each kept
with the clock that clocks it, and the outputs are held between their clock's activations. A step at tick k runs no
fmi3DoStep; it activates the partitions due at k one after the other, in the order of their declared priorities
(smaller first; equal ones in declaration order: the standard leaves that to the importer):

    set the inputs no clock clocks -> for each due partition: set the inputs it clocks
    -> fmi3ActivateModelPartition(clock, t) -> get the outputs it clocks

This path never preempts (one partition runs at a time, to its end); the preemption lock callbacks it hands the FMU
count the calls and check that they balance. The C tick loop runs this same sequence itself (native/clocks.py,
tl_loop.c's activate_partitions), reading the lock count the callbacks keep; do_step here is the path of the loop's
Python callback (asked for, to hold the two side by side).
"""

from __future__ import annotations

import ctypes
import os
import time

from fmpy.fmi3 import (
    FMU3ScheduledExecution,
    fmi3Boolean,
    fmi3ClockUpdateCallback,
    fmi3InstanceEnvironment,
    fmi3LockPreemptionCallback,
    fmi3LogMessageCallback,
    fmi3UnlockPreemptionCallback,
)

from ..errors import ExecutionError
from .fmi3 import Fmu3Slave


class Fmu3ScheduledSlave(Fmu3Slave):
    """One instantiated FMI 3.0 Scheduled Execution FMU; tick: the execution's, which places the activations."""

    scheduled = True
    count_locks = True

    def _instantiate(self, md, name: str):
        self.locks = 0  # lock callbacks received
        self.lock_depth = ctypes.c_int(0)  # locks held: a C int, so the C tick loop checks it after an activation

        def lock() -> None:
            self.locks += 1
            self.lock_depth.value += 1

        def unlock() -> None:
            self.lock_depth.value -= 1
        # FMPy's instantiate hands the FMU no-op lock callbacks; these count (kept on the slave: the FMU holds them).
        # count_locks False (benchmarks/fmi3.py, to price them): none given, which the FMU takes as no-ops
        locking = (fmi3LockPreemptionCallback(lock), fmi3UnlockPreemptionCallback(unlock)) if self.count_locks else \
            (fmi3LockPreemptionCallback(), fmi3UnlockPreemptionCallback())
        self._callbacks = (fmi3LogMessageCallback(self._log_message), fmi3ClockUpdateCallback(lambda env: None), *locking)

        def instantiate(fmu) -> None:
            resources = os.path.join(self.dir, "resources") + os.path.sep
            fmu.component = fmu.fmi3InstantiateScheduledExecution(
                name.encode(), md.guid.encode(), resources.encode(), fmi3Boolean(False), fmi3Boolean(True),
                fmi3InstanceEnvironment(), *self._callbacks)
            if not fmu.component:
                raise Exception("Failed to instantiate FMU")
        return self._load(lambda folder: FMU3ScheduledExecution(guid=md.guid, unzipDirectory=folder,
                                                                modelIdentifier=md.scheduledExecution.modelIdentifier,
                                                                instanceName=name), instantiate)

    def _bind(self) -> None:
        super()._bind()
        dll = self.fmu.dll
        self._activate = dll.fmi3ActivateModelPartition
        self._activate.argtypes = [ctypes.c_void_p, ctypes.c_uint, ctypes.c_double]
        self._activate.restype = ctypes.c_int
        self._rank = {j: (k.priority, j) for j, k in enumerate(self.clocks)}
        self.rank_order = sorted(self._rank, key=self._rank.__getitem__)  # every clock, smaller priority first
        self._order: dict[tuple[int, ...], list[int]] = {}  # due clocks -> them in priority order

    @property
    def can_serialize(self) -> bool:
        se = self.md.scheduledExecution
        return bool(se.canGetAndSetFMUstate and se.canSerializeFMUstate)  # FMPy's spelling for every version

    def initialize(self, parameters: dict, start: float = 0.0) -> None:
        super().initialize(parameters, start=start)
        self._in_event = False  # Clock Activation Mode: no Event Mode here
        self.lock_depth.value = 0  # a run ended by a partition that returned locked leaves nothing held to the next

    def do_step(self, t: float, h: float) -> None:
        k = round(t / self.tick)
        due = tuple(self._due(k))
        order = self._order.get(due)
        if order is None:
            order = self._order[due] = sorted(due, key=self._rank.__getitem__)
        self._set({"continuous", "discrete"}, t)
        for j in order:
            clock = self.clocks[j]
            self._set({j}, t)
            self._activate_partition(clock.value_reference, clock.name, t)
            self.activations[clock.name].append(k)
            self._read(self._clocked_outputs.get(j, ()), "get clocked outputs", t)

    def _activate_partition(self, vr: int, name: str, t: float) -> None:
        started = time.perf_counter()
        status = self._activate(self.component, vr, t)
        self.fmi_seconds += time.perf_counter() - started
        if status > 1:
            raise self.failed(f"activateModelPartition({name}) at t={t:.6g} s", status)
        if self.lock_depth.value != 0:
            raise ExecutionError(f"{self.name}: partition {name} returned at t={t:.6g} s with {self.lock_depth.value} "
                                 "preemption lock(s) held")

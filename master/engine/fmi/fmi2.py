"""An FMI 2.0 co-simulation FMU loaded into this process: the engine's fast path.

The hot path calls the FMU's own fmi2 functions through ctypes on arrays allocated once:
`values[type]` is a numpy view of the array fmi2Get<type> writes into, so reading the outputs
is one foreign call per type and nothing is copied or converted.
"""

from __future__ import annotations

import ctypes
import time
from pathlib import Path

import numpy as np
from fmpy.fmi1 import calloc, free
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
)

from ..errors import FmuEndedRun
from .binaries import library_path
from .binding import Binding, c_function
from .pythonfmu_guard import pin
from .slave import C_TYPES, TYPES


class InProcessFmu(Binding):
    """One instantiated FMU in this process: typed output tables, captured log, fatal-aware teardown."""

    PARAMETER_SETTERS = {"Float64": "setReal", "Int32": "setInteger", "Enumeration": "setInteger", "Boolean": "setBoolean",
                         "String": "setString"}

    def __init__(self, name: str, path: Path, md) -> None:
        super().__init__(name, path, md)
        pin(path)  # pythonfmu FMUs crash when reloaded unless one copy stays loaded (harmless for others)

        def logger(env, inst, status, category, message):
            self.log.append(message.decode("utf-8", "replace"))
        self._callbacks = fmi2CallbackFunctions()
        self._callbacks.logger = fmi2CallbackLoggerTYPE(logger)
        self._callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        self._callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        identifier = md.coSimulation.modelIdentifier
        self.slave = self._load(
            lambda folder: FMU2Slave(guid=md.guid, unzipDirectory=folder, modelIdentifier=identifier, instanceName=name,
                                     libraryPath=library_path(folder, identifier)),
            lambda slave: slave.instantiate(loggingOn=True, callbacks=self._callbacks))
        self._bind()

    def _bind(self) -> None:
        """The raw fmi2 functions and the output arrays, set up once."""
        dll = self.slave.dll
        self._do_step = c_function(dll, "fmi2DoStep", [ctypes.c_void_p, ctypes.c_double, ctypes.c_double, ctypes.c_int])
        self.getters = {}
        for t in TYPES:
            for kind, table in (("Get", self.getters), ("Set", self.setters)):
                table[t] = c_function(dll, f"fmi2{kind}{t}", [ctypes.c_void_p, ctypes.POINTER(ctypes.c_uint), ctypes.c_size_t,
                                                              ctypes.POINTER(C_TYPES[t])])
        self._reads = []
        for t in TYPES:
            n = len(self.out_vrs[t])
            buf = (C_TYPES[t] * max(n, 1))()
            self.values[t] = np.ctypeslib.as_array(buf)[:n]
            if n:
                self._reads.append((t, self.getters[t], (ctypes.c_uint * n)(*self.out_vrs[t]), n, buf))
        self.component = self.slave.component

    connects_in_initialization = True  # the master may set its connected inputs in Initialization Mode

    def initialize(self, parameters: dict, connect=None, start: float = 0.0) -> None:
        """connect(): the master sets the connected inputs in Initialization Mode (engine/edges.py), where the FMU's
        outputs follow them (a feedthrough's sample at t = 0 holds the connected values). start: the system's start."""
        self.call("setupExperiment", lambda: self.slave.setupExperiment(startTime=float(start)))
        self.call("enterInitializationMode", self.slave.enterInitializationMode)
        self.set_parameters(parameters)
        if connect is not None:
            connect()
        self.call("exitInitializationMode", self.slave.exitInitializationMode)
        self.read_outputs()

    def reset(self) -> None:
        self.call("reset", self.slave.reset)

    def read_outputs(self) -> None:
        started = time.perf_counter()
        component = self.component
        for t, get, vrs, n, buf in self._reads:
            status = get(component, vrs, n, buf)
            if status > 1:
                self.fmi_seconds += time.perf_counter() - started
                raise self.failed(f"get{t}", status)
        self.fmi_seconds += time.perf_counter() - started

    def do_step(self, t: float, h: float) -> None:
        started = time.perf_counter()
        status = self._do_step(self.component, t, h, 1)
        self.fmi_seconds += time.perf_counter() - started
        if status == 2 and self._terminated():  # fmi2Discard, and the FMU says it ended the simulation
            raise FmuEndedRun(self.name, self._last_successful_time(t), self.failed(f"doStep at t={t:.6g} s", status))
        if status > 1:
            raise self.failed(f"doStep at t={t:.6g} s", status)

    def _terminated(self) -> bool:
        try:
            return bool(self.slave.getBooleanStatus(3))  # fmi2Terminated
        except Exception:
            return False

    def _last_successful_time(self, t: float) -> float:
        try:
            return float(self.slave.getRealStatus(2))  # fmi2LastSuccessfulTime
        except Exception:
            return t

    def get_state(self) -> bytes:
        def serialize():
            state = self.slave.getFMUstate()
            try:
                return self.slave.serializeFMUstate(state)
            finally:
                self.slave.freeFMUstate(state)
        return self.call("getting its state", serialize)

    def set_state(self, state: bytes) -> None:
        def restore():
            fmu_state = self.slave.deSerializeFMUstate(state)
            try:
                self.slave.setFMUstate(fmu_state)
            finally:
                self.slave.freeFMUstate(fmu_state)
        self.call("restoring its state", restore)
        self.read_outputs()

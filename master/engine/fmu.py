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
from fmpy.fmi1 import FMICallException, calloc, free
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
)

from .binaries import library_path
from .errors import ExecutionError
from .fmu_cache import unpacked
from .model_description import checked_value
from .pythonfmu_guard import pin
from .slave import C_TYPES, TYPES, Slave


def fmpy_call(slave: Slave, what: str, fn):
    """fn() through FMPy, timed into the slave's fmi_seconds; a refused call becomes the slave's one-line error."""
    started = time.perf_counter()
    try:
        return fn()
    except FMICallException as err:
        raise slave.failed(what, err.status) from None
    except OSError as err:
        raise ExecutionError(f"{slave.name}: {what} failed: {err}") from None
    finally:
        slave.fmi_seconds += time.perf_counter() - started


class InProcessFmu(Slave):
    """One instantiated FMU in this process: typed output tables, captured log, fatal-aware teardown."""

    def __init__(self, name: str, path: Path, md) -> None:
        super().__init__(name, path, md)
        self._closed = False
        pin(path)  # pythonfmu FMUs crash when reloaded unless one copy stays loaded (harmless for others)
        self._unpacked = unpacked(path)  # the machine's cached copy (fmu_cache.py), or a private one removed by close()
        self.dir = self._unpacked.folder

        def logger(env, inst, status, category, message):
            self.log.append(message.decode("utf-8", "replace"))
        self._callbacks = fmi2CallbackFunctions()
        self._callbacks.logger = fmi2CallbackLoggerTYPE(logger)
        self._callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        self._callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        try:
            self.slave = FMU2Slave(guid=md.guid, unzipDirectory=self.dir, modelIdentifier=md.coSimulation.modelIdentifier,
                                   instanceName=name, libraryPath=library_path(self.dir, md.coSimulation.modelIdentifier))
            self.call("instantiate", lambda: self.slave.instantiate(loggingOn=True, callbacks=self._callbacks))
        except BaseException:
            self._unpacked.release()  # nothing of a failed instantiation stays behind
            raise
        self._bind()

    def _bind(self) -> None:
        """The raw fmi2 functions and the output arrays, set up once."""
        dll = self.slave.dll
        self._do_step = dll.fmi2DoStep
        self._do_step.argtypes = [ctypes.c_void_p, ctypes.c_double, ctypes.c_double, ctypes.c_int]
        self._do_step.restype = ctypes.c_int
        self.getters = {}
        for t in TYPES:
            for kind, table in (("Get", self.getters), ("Set", self.setters)):
                fn = getattr(dll, f"fmi2{kind}{t}")
                fn.argtypes = [ctypes.c_void_p, ctypes.POINTER(ctypes.c_uint), ctypes.c_size_t, ctypes.POINTER(C_TYPES[t])]
                fn.restype = ctypes.c_int
                table[t] = fn
        self._reads = []
        for t in TYPES:
            n = len(self.out_vrs[t])
            buf = (C_TYPES[t] * max(n, 1))()
            self.values[t] = np.ctypeslib.as_array(buf)[:n]
            if n:
                self._reads.append((t, self.getters[t], (ctypes.c_uint * n)(*self.out_vrs[t]), n, buf))
        self.component = self.slave.component

    def function_pointer(self, name: str) -> int:
        """The address of one of the FMU's own functions (fmi2DoStep, fmi2SetReal, ...), for the C tick loop."""
        return ctypes.cast(getattr(self.slave.dll, name), ctypes.c_void_p).value

    def call(self, what: str, fn):
        return fmpy_call(self, what, fn)

    def initialize(self, parameters: dict) -> None:
        self.call("setupExperiment", lambda: self.slave.setupExperiment(startTime=0.0))
        self.call("enterInitializationMode", self.slave.enterInitializationMode)
        self.set_parameters(parameters)
        self.call("exitInitializationMode", self.slave.exitInitializationMode)
        self.read_outputs()

    def reset(self) -> None:
        self.call("reset", self.slave.reset)

    def set_values(self, values: dict) -> None:
        self.set_parameters(values)

    def set_parameters(self, params: dict) -> None:
        for key, value in params.items():
            v = self.vars.get(key)
            value = checked_value(self.name, v, key, value)
            setter = {"Real": self.slave.setReal, "Integer": self.slave.setInteger, "Boolean": self.slave.setBoolean,
                      "String": self.slave.setString}[v.type]
            self.call(f"setting {key}", lambda s=setter, vr=v.valueReference, x=value: s([vr], [x]))

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
        if status > 1:
            raise self.failed(f"doStep at t={t:.6g} s", status)

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

    def close(self) -> None:
        """Terminate and free the instance, then remove its extracted copy (a run leaves no folder behind)."""
        if self._closed:
            return
        self._closed = True
        if not self.fatal:  # after fmi2Fatal the standard allows no call, not even fmi2FreeInstance
            try:
                self.slave.terminate()
            except Exception:
                pass
            try:
                self.slave.freeInstance()
            except Exception:
                pass
        self._unpacked.release()

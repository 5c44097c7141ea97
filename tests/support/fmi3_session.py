"""FMPy helpers for driving an FMI 3.0 co-simulation FMU step by step in tests, with its log captured."""

from __future__ import annotations

import ctypes
import shutil
from contextlib import contextmanager

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi3 import FMU3Slave, fmi3Boolean, fmi3Float64

GETTERS = {"Float64": "getFloat64", "Int32": "getInt32", "Boolean": "getBoolean", "String": "getString"}
SETTERS = {"Float64": "setFloat64", "Int32": "setInt32", "Boolean": "setBoolean", "String": "setString"}


class Session3:
    """One instantiated FMI 3.0 co-simulation FMU: name-based get/set of any type, the log, raw DoStep results."""

    def __init__(self, fmu_path, instance="fmu", event_mode=False, start=True):
        self.md = read_model_description(str(fmu_path))
        self.dir = extract(str(fmu_path))
        self.vars = {v.name: v for v in self.md.modelVariables}
        self.vr = {n: v.valueReference for n, v in self.vars.items()}
        self.log: list[tuple[int, str, str]] = []  # (status, category, message)
        self.fmu = FMU3Slave(guid=self.md.guid, unzipDirectory=self.dir,
                             modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=instance)

        def log_message(env, status, category, message):
            self.log.append((status, category.decode() if category else "", message.decode("utf-8", "replace")))
        try:
            self.fmu.instantiate(loggingOn=True, eventModeUsed=event_mode, logMessage=log_message)
        except Exception:
            shutil.rmtree(self.dir, ignore_errors=True)
            raise
        if start:
            self.fmu.enterInitializationMode(startTime=0.0)

    def said(self, needle: str) -> bool:
        return any(needle in message for _, _, message in self.log)

    def set(self, **values):
        for name, value in values.items():
            v = self.vars[name]
            getattr(self.fmu, SETTERS[v.type])([v.valueReference], [value])

    def get(self, *names):
        out = []
        for name in names:
            v = self.vars[name]
            out.append(getattr(self.fmu, GETTERS[v.type])([v.valueReference])[0])
        return out

    def reals(self, *names) -> np.ndarray:
        return np.array(self.fmu.getFloat64([self.vr[n] for n in names]))

    def do_step(self, t: float, h: float) -> tuple[int, bool, bool, bool, float]:
        """fmi3DoStep without FMPy's exception: (status, eventHandlingNeeded, terminate, earlyReturn, lastSuccessfulTime)."""
        event, terminate, early, last = fmi3Boolean(), fmi3Boolean(), fmi3Boolean(), fmi3Float64()
        fn = self.fmu.dll.fmi3DoStep
        fn.restype = ctypes.c_int
        status = fn(self.fmu.component, ctypes.c_double(t), ctypes.c_double(h), fmi3Boolean(True), ctypes.byref(event),
                    ctypes.byref(terminate), ctypes.byref(early), ctypes.byref(last))
        return status, event.value, terminate.value, early.value, last.value

    def close(self):
        try:
            self.fmu.terminate()
        except Exception:
            pass
        try:
            self.fmu.freeInstance()
        except Exception:
            pass
        shutil.rmtree(self.dir, ignore_errors=True)


@contextmanager
def session3(fmu_path, **kw):
    s = Session3(fmu_path, **kw)
    try:
        yield s
    finally:
        s.close()

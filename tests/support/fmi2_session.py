"""Small FMPy helpers for driving an FMU step by step in tests, with its log captured."""

from __future__ import annotations

import shutil
from contextlib import contextmanager

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi1 import calloc, free
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
)


class Session:
    """One instantiated co-simulation FMU with name-based access and a captured log."""

    def __init__(self, fmu_path, instance="plant"):
        self.md = read_model_description(fmu_path)
        self.dir = extract(fmu_path)
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.log: list[str] = []
        self.fatal = False
        self.fmu = FMU2Slave(
            guid=self.md.guid, unzipDirectory=self.dir,
            modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=instance,
        )
        def logger(env, instance, status, category, message):
            self.log.append(message.decode("utf-8", "replace"))

        self._callbacks = fmi2CallbackFunctions()
        self._callbacks.logger = fmi2CallbackLoggerTYPE(logger)
        self._callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        self._callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        self.fmu.instantiate(loggingOn=True, callbacks=self._callbacks)
        self.fmu.setupExperiment(startTime=0.0)
        self.fmu.enterInitializationMode()

    def set(self, **values):
        self.fmu.setReal([self.vr[k] for k in values], [float(v) for v in values.values()])

    def get(self, *names):
        return np.array(self.fmu.getReal([self.vr[n] for n in names]))

    def set_typed(self, **values):
        """Integer, Boolean or String variables, by the type the model description declares."""
        types = {v.name: v.type for v in self.md.modelVariables}
        for name, value in values.items():
            setter = {"Integer": self.fmu.setInteger, "Boolean": self.fmu.setBoolean, "String": self.fmu.setString}[types[name]]
            setter([self.vr[name]], [value])

    def get_bool(self, *names):
        return list(self.fmu.getBoolean([self.vr[n] for n in names]))

    def start(self):
        try:
            self.fmu.exitInitializationMode()
        except Exception as err:
            # after fmi2Fatal the FMI standard allows no further call, not even fmi2FreeInstance
            self.fatal = getattr(err, "status", None) == 4
            raise

    def run(self, stop, dt, record=(), inputs=None):
        """Step to stop with step dt; record the named outputs at every communication point."""
        t, rows = 0.0, [self.get(*record)] if record else []
        for k in range(int(round(stop / dt))):
            if inputs is not None:
                self.set(**inputs(t))
            self.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=dt)
            t = (k + 1) * dt
            if record:
                rows.append(self.get(*record))
        return np.array(rows)

    def close(self):
        if self.fatal:
            return
        try:
            self.fmu.terminate()
        except Exception:
            pass
        self.fmu.freeInstance()
        shutil.rmtree(self.dir, ignore_errors=True)


@contextmanager
def session(fmu_path, **kw):
    s = Session(fmu_path, **kw)
    try:
        yield s
    finally:
        s.close()


HOVER_THRUSTS = "9.987293721113877, 10.02221862357339, 0.0, 0.0"  # the load system's trim inputs


def wrap_misbehaving(folder, acts: dict[str, str], at: float) -> dict:
    """One `tiltload wrap` controller per entry of acts ({mode: a Python statement}) that hovers until t >= at,
    then runs its statement (segfault, exit, hang, return NaN ...); returns {mode: FMU path}."""
    from tiltload.master.app.cli import main

    out = {}
    for mode, act in acts.items():
        name = mode.replace(" ", "_")
        src = folder / f"bad_{name}.py"
        src.write_text(f"import os, signal, time\n\nclass Bad{name.title().replace('_', '')}:\n    inputs = ['x_ref']\n\n"
                       f"    def step(self, t, i):\n        if t >= {at}:\n            {act}\n        return {HOVER_THRUSTS}\n")
        out[mode] = folder / f"bad_{name}.fmu"
        assert main(["wrap", str(src), "--out", str(out[mode])]) == 0
    return out


def foreign_copy(fmu, dest, drop=("resources/build_info.json",)):
    """A copy of one of our FMUs without its build record: the master treats it as foreign (runs it isolated)."""
    import zipfile

    with zipfile.ZipFile(fmu) as src, zipfile.ZipFile(dest, "w") as out:
        for item in src.infolist():
            if not any(item.filename.startswith(d) for d in drop):
                out.writestr(item, src.read(item.filename))
    return dest

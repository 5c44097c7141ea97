"""The execution: owns the clock and the FMU instances, steps them on the fixed-step multirate schedule.

Algorithm (DESIGN §4): one tick T; an instance of period P = nT is stepped doStep(t_k, P) at
the ticks k with k % n == 0, in the system's order (for tiltload: scenario, sensors,
controller, plant). Before an instance steps, its connected inputs are set from the latest
outputs of their sources (or from d ticks back, for a connection with delay d). Observers
only read: they see each instance's outputs after its step. Every FMI failure becomes an
ExecutionError naming the instance, the call and the FMU's last log line.
"""

from __future__ import annotations

import ctypes
import math
import time
import zipfile
from collections import deque
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException, calloc, free
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
)

from . import connections
from .pythonfmu_guard import pin
from .system import DescriptionError, System, validate

FATAL = 4
STATUS = {1: "warning", 2: "discard", 3: "error", 4: "fatal", 5: "pending"}
_C_TYPE = {"Real": ctypes.c_double, "Integer": ctypes.c_int, "Boolean": ctypes.c_int}  # fmi2Boolean is an int


class ExecutionError(RuntimeError):
    """A failure while running; the message names the instance, the call and the FMU's own words."""


def read_fmu(path: Path, instance: str):
    """Model description of a co-simulation FMU, or a DescriptionError saying what the file is not."""
    path = Path(path)
    if not path.is_file():
        raise DescriptionError(f"{instance}: FMU file {path} does not exist")
    if not zipfile.is_zipfile(path):
        raise DescriptionError(f"{instance}: {path} is not an FMU (not a zip archive)")
    try:
        md = read_model_description(str(path), validate=False)
    except Exception as err:  # fmpy raises various types for a broken modelDescription.xml
        raise DescriptionError(f"{instance}: {path} is not a valid FMU ({err})") from None
    if md.fmiVersion != "2.0":
        raise DescriptionError(f"{instance}: {path} is FMI {md.fmiVersion}; only FMI 2.0 co-simulation is supported")
    if md.coSimulation is None:
        raise DescriptionError(f"{instance}: {path} is a model-exchange-only FMU; a co-simulation FMU is needed")
    return md


def checked_value(instance: str, v, key: str, value):
    """A parameter (or unconnected input) value converted to the variable's FMI type, or a DescriptionError
    naming it: unknown or unsettable variable, wrong kind, non-finite, outside the declared min/max or int32."""
    if v is None:
        raise DescriptionError(f"{instance} has no variable '{key}' to set")
    if v.causality not in ("parameter", "input") or v.variability == "constant":
        raise DescriptionError(f"{instance}.{key} is a {v.causality} ({v.variability}); only parameters and inputs can be set")
    where = f"{instance}.{key} = {value!r}"
    if v.type in ("Real", "Integer"):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise DescriptionError(f"{where}: must be a number")
        if not math.isfinite(value):
            raise DescriptionError(f"{where}: must be finite")
        if v.type == "Integer":
            if value != int(value) or not -2**31 <= value < 2**31:
                raise DescriptionError(f"{where}: must be a whole number that fits 32 bits")
            value = int(value)
        else:
            value = float(value)
        lo, hi = (None if b is None else float(b) for b in (v.min, v.max))
        if (lo is not None and value < lo) or (hi is not None and value > hi):
            raise DescriptionError(f"{where}: outside its declared range [{lo if lo is not None else '-inf'}, "
                                   f"{hi if hi is not None else 'inf'}]")
        return value
    if v.type == "Boolean":
        if isinstance(value, bool) or value in (0, 1):
            return bool(value)
        raise DescriptionError(f"{where}: must be true or false")
    return str(value)


class FmuInstance:
    """One instantiated FMU: typed output tables, captured log, fatal-aware teardown.

    The hot path calls the FMU's own fmi2 functions through ctypes on arrays allocated once:
    `values[type]` is a numpy view of the array fmi2Get<type> writes into, so reading the outputs
    is one foreign call per type and nothing is copied or converted.
    """

    def __init__(self, name: str, path: Path, md) -> None:
        self.name, self.path, self.md = name, Path(path), md
        self.log: list[str] = []
        self.fatal = False
        self.fmi_seconds = 0.0  # wall time inside FMI calls (the rest of a run is the master's share)
        self.outputs = {t: [v for v in md.modelVariables if v.causality == "output" and v.type == t] for t in connections.TYPES}
        self.out_vrs = {t: [v.valueReference for v in vs] for t, vs in self.outputs.items()}
        self.out_index = {t: {v.valueReference: i for i, v in enumerate(vs)} for t, vs in self.outputs.items()}
        self.vars = {v.name: v for v in md.modelVariables}
        pin(path)  # pythonfmu FMUs crash when reloaded unless one copy stays loaded (harmless for others)
        self.dir = extract(str(path))

        def logger(env, inst, status, category, message):
            self.log.append(message.decode("utf-8", "replace"))
        self._callbacks = fmi2CallbackFunctions()
        self._callbacks.logger = fmi2CallbackLoggerTYPE(logger)
        self._callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        self._callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        self.slave = FMU2Slave(guid=md.guid, unzipDirectory=self.dir, modelIdentifier=md.coSimulation.modelIdentifier,
                               instanceName=name)
        self.call("instantiate", lambda: self.slave.instantiate(loggingOn=True, callbacks=self._callbacks))
        self._bind()

    def _bind(self) -> None:
        """The raw fmi2 functions and the output arrays, set up once."""
        dll = self.slave.dll
        self._do_step = dll.fmi2DoStep
        self._do_step.argtypes = [ctypes.c_void_p, ctypes.c_double, ctypes.c_double, ctypes.c_int]
        self._do_step.restype = ctypes.c_int
        self.getters, self.setters = {}, {}
        for t in connections.TYPES:
            for kind, table in (("Get", self.getters), ("Set", self.setters)):
                fn = getattr(dll, f"fmi2{kind}{t}")
                fn.argtypes = [ctypes.c_void_p, ctypes.POINTER(ctypes.c_uint), ctypes.c_size_t, ctypes.POINTER(_C_TYPE[t])]
                fn.restype = ctypes.c_int
                table[t] = fn
        self._reads, self.values = [], {}
        for t in connections.TYPES:
            n = len(self.out_vrs[t])
            buf = (_C_TYPE[t] * max(n, 1))()
            self.values[t] = np.ctypeslib.as_array(buf)[:n]
            if n:
                self._reads.append((t, self.getters[t], (ctypes.c_uint * n)(*self.out_vrs[t]), n, buf))

    @property
    def component(self):
        """The fmi2Component the raw setters take."""
        return self.slave.component

    def failed(self, what: str, status: int) -> ExecutionError:
        self.fatal = status == FATAL
        said = next((line for line in reversed(self.log) if line.strip() and "Fatal py exception" not in line), "")
        return ExecutionError(f"{self.name}: {what} failed ({STATUS.get(status, status)})" + (f": {said}" if said else ""))

    def call(self, what: str, fn):
        started = time.perf_counter()
        try:
            return fn()
        except FMICallException as err:
            raise self.failed(what, err.status) from None
        except OSError as err:
            raise ExecutionError(f"{self.name}: {what} failed: {err}") from None
        finally:
            self.fmi_seconds += time.perf_counter() - started

    def initialize(self, parameters: dict) -> None:
        """setupExperiment, parameters, initialization mode, then the outputs at t = 0."""
        self.call("setupExperiment", lambda: self.slave.setupExperiment(startTime=0.0))
        self.call("enterInitializationMode", self.slave.enterInitializationMode)
        self.set_parameters(parameters)
        self.call("exitInitializationMode", self.slave.exitInitializationMode)
        self.read_outputs()

    def reset(self) -> None:
        self.call("reset", self.slave.reset)

    def set_parameters(self, params: dict) -> None:
        for key, value in params.items():
            v = self.vars.get(key)
            value = checked_value(self.name, v, key, value)
            setter = {"Real": self.slave.setReal, "Integer": self.slave.setInteger, "Boolean": self.slave.setBoolean,
                      "String": self.slave.setString}[v.type]
            self.call(f"setting {key}", lambda s=setter, vr=v.valueReference, x=value: s([vr], [x]))

    def read_outputs(self) -> None:
        started = time.perf_counter()
        component = self.slave.component
        for t, get, vrs, n, buf in self._reads:
            status = get(component, vrs, n, buf)
            if status > 1:
                self.fmi_seconds += time.perf_counter() - started
                raise self.failed(f"get{t}", status)
        self.fmi_seconds += time.perf_counter() - started

    def do_step(self, t: float, h: float) -> None:
        started = time.perf_counter()
        status = self._do_step(self.slave.component, t, h, 1)
        self.fmi_seconds += time.perf_counter() - started
        if status > 1:
            raise self.failed(f"doStep at t={t:.6g} s", status)

    def close(self) -> None:
        """Terminate and free the instance, then remove its extracted copy (a run leaves no folder behind)."""
        if not self.fatal:  # after fmi2Fatal the standard allows no call, not even fmi2FreeInstance
            try:
                self.slave.terminate()
            except Exception:
                pass
            try:
                self.slave.freeInstance()
            except Exception:
                pass
        import shutil

        shutil.rmtree(self.dir, ignore_errors=True)


def _check_parameters(system: System, mds: dict, links) -> None:
    """Every given value fits its variable, and none is for an input a connection overwrites every step."""
    fed = {(link.target, link.type, link.target_vr): link for link in links}
    for spec in system.instances:
        variables = {v.name: v for v in mds[spec.name].modelVariables}
        for key, value in spec.parameters.items():
            v = variables.get(key)
            checked_value(spec.name, v, key, value)
            link = fed.get((spec.name, v.type, v.valueReference)) if v.causality == "input" else None
            if link is not None:
                source = f"{link.source}.{_name_of(mds[link.source], link.type, link.source_vr)}"
                raise DescriptionError(f"{spec.name}.{key} is an input fed by {source} every step: setting it has no effect")


def _name_of(md, typ: str, vr: int) -> str:
    return next((v.name for v in md.modelVariables if v.valueReference == vr and v.type == typ and v.causality == "output"), str(vr))


@dataclass
class _Group:
    """Links from one source into one target of one type and delay: a gather into an array the set reads."""

    source: str
    target: str
    type: str
    delay: int
    src_index: np.ndarray
    dst_vrs: object  # ctypes array of the target's value references
    values: object  # ctypes array the set reads; `view` is it as numpy
    view: np.ndarray
    setter: object  # the target's raw fmi2Set<type>


class Execution:
    def __init__(self, system: System, observers=(), trust_fmus: bool = False, step_timeout: float | None = None) -> None:
        """trust_fmus: run every FMU in this process; else FMUs tiltload did not build run each in
        its own process, every call watched for step_timeout seconds (fmu_process.py)."""
        self.system = validate(system)
        self.trust_fmus, self.step_timeout = trust_fmus, step_timeout
        self.observers = list(observers)
        self.instances: dict[str, FmuInstance] = {}
        self.time = 0.0
        self.ticks_done = 0
        mds = {i.name: read_fmu(i.fmu, i.name) for i in system.instances}
        self.links = connections.resolve(system, mds)
        _check_parameters(system, mds, self.links)
        self.unconnected = connections.unconnected(system, mds, self.links)  # held for the whole run: said before it starts
        self.every = {i.name: (1 if i.period is None else round(i.period / system.tick)) for i in system.instances}
        groups: dict[tuple, list] = {}
        for link in self.links:
            groups.setdefault((link.source, link.target, link.type, link.delay), []).append(link)
        self._mds = mds
        self._raw_groups = groups
        self.groups: dict[str, list[_Group]] = {}
        self.max_delay = max((link.delay for link in self.links), default=0)
        self.history: dict[str, deque] = {}
        self.manipulator = None
        if system.faults:
            from .manipulators import FaultError, Manipulator

            self.manipulator = Manipulator(system.faults)
            try:
                self.manipulator.check(mds, self.links)
            except FaultError as err:
                raise DescriptionError(str(err)) from None

    def instantiate(self) -> None:
        try:
            from .fmu_process import STEP_TIMEOUT, IsolatedFmu, is_ours

            for spec in self.system.instances:
                md = self._mds[spec.name]
                if self.trust_fmus or is_ours(spec.fmu, md):
                    self.instances[spec.name] = FmuInstance(spec.name, spec.fmu, md)
                else:
                    self.instances[spec.name] = IsolatedFmu(spec.name, spec.fmu, md, self.step_timeout or STEP_TIMEOUT)
            for (src, dst, typ, delay), links in self._raw_groups.items():
                idx = np.array([self.instances[src].out_index[typ][link.source_vr] for link in links], dtype=int)
                buf = (_C_TYPE[typ] * len(links))()
                vrs = (ctypes.c_uint * len(links))(*[link.target_vr for link in links])
                self.groups.setdefault(dst, []).append(_Group(src, dst, typ, delay, idx, vrs, buf, np.ctypeslib.as_array(buf),
                                                              self.instances[dst].setters[typ]))
            if self.manipulator is not None:
                self.manipulator.bind(self)
        except BaseException:
            raise  # the caller's close() frees what was instantiated
        self._initialize()

    def _initialize(self) -> None:
        """Set-up, parameters and initialization of every instance, then the observers start at t = 0."""
        for spec in self.system.instances:
            self.instances[spec.name].initialize(spec.parameters)
        self.time, self.ticks_done = 0.0, 0
        for name, inst in self.instances.items():
            self.history[name] = deque([{t: v.copy() for t, v in inst.values.items()}], maxlen=self.max_delay + 1)
        for obs in self.observers:
            obs.start(self)

    def restart(self, parameters: dict[str, dict] | None = None, observers=None, faults=None) -> None:
        """A new run on the same FMU instances: fmi2Reset, then initialization with these parameters
        ({instance: {name: value}}, replacing the given instances' parameters) and these observers.
        Cheaper than instantiating again (campaigns run many runs on one set of FMUs per worker)."""
        for name, values in (parameters or {}).items():
            self.system.instance(name).parameters = dict(values)
        _check_parameters(self.system, self._mds, self.links)
        if observers is not None:
            self.observers = list(observers)
        if faults is not None:  # a new fault schedule (a list, possibly empty)
            from .manipulators import Manipulator

            self.system.faults = list(faults)
            self.manipulator = Manipulator(self.system.faults) if faults else None
            if self.manipulator is not None:
                self.manipulator.check(self._mds, self.links)
                self.manipulator.bind(self)
        elif self.manipulator is not None:
            self.manipulator = type(self.manipulator)(self.system.faults)  # fresh state: holds, histories
            self.manipulator.bind(self)
        for spec in self.system.instances:
            self.instances[spec.name].reset()
        self._initialize()

    def _set_inputs(self, name: str, t: float) -> None:
        inst = self.instances[name]
        component = inst.component
        groups = self.groups.get(name, ())
        for g in groups:
            if g.delay == 0:
                src = self.instances[g.source].values[g.type]
            else:
                hist = self.history[g.source]
                src = hist[max(len(hist) - g.delay, 0)][g.type]
            np.take(src, g.src_index, out=g.view)
        if self.manipulator is not None:
            self.manipulator.apply(name, "input", t, self.observers)
        for g in groups:
            started = time.perf_counter()
            status = g.setter(component, g.dst_vrs, len(g.view), g.values)
            inst.fmi_seconds += time.perf_counter() - started
            if status > 1:
                raise inst.failed(f"set{g.type} from {g.source} at t={t:.6g} s", status)

    def step_tick(self) -> None:
        k, tick = self.ticks_done, self.system.tick
        t = k * tick
        for spec in self.system.instances:
            n = self.every[spec.name]
            if k % n:
                continue
            inst = self.instances[spec.name]
            self._set_inputs(spec.name, t)
            inst.do_step(t, n * tick)
            inst.read_outputs()
            if self.manipulator is not None:
                self.manipulator.apply(spec.name, "output", t, self.observers)
            when = t + n * tick if spec.timing == "continuous" else t
            for obs in self.observers:
                obs.on_step(inst, when)
        if self.max_delay:
            for name, inst in self.instances.items():
                self.history[name].append({typ: v.copy() for typ, v in inst.values.items()})
        self.ticks_done = k + 1
        self.time = self.ticks_done * tick
        for obs in self.observers:
            obs.on_tick(self.ticks_done, self.time)

    def run(self, stop: float) -> None:
        n = int(round(stop / self.system.tick))
        while self.ticks_done < n:
            self.step_tick()

    def close(self, error: str | None = None) -> None:
        """Finish the observers (the log first), then free the instances; safe to call twice."""
        observers, self.observers = self.observers, []
        for obs in observers:
            try:
                obs.finish(self, error)
            except Exception:
                pass
        instances, self.instances = self.instances, {}
        for inst in instances.values():
            inst.close()

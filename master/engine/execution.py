"""The execution: owns the clock and the FMU instances, steps them on the fixed-step multirate schedule.

Algorithm (docs/master.md, "Semantics"): one tick T; an instance of period P = nT is stepped
doStep(t_k, P) at the ticks k with k % n == 0, in the system's order. Before an instance steps,
its connected inputs are set from the latest outputs of their sources (or from d ticks back, for
a connection with delay d). Observers only read: they see each instance's outputs after its
step. Every FMI failure becomes an ExecutionError naming the instance, the call and the FMU's
last log line.

The execution checks the system, loads the FMUs and builds the plan; the ticks themselves run in C
(native/tl_loop.c), many per call, calling the FMUs' own fmi2 functions. Python steps in only where
it must: an FMU in a worker process (or any slave without fmi2 function pointers) and faults are
called back from the loop, and the observers read each call's records afterwards.
"""

from __future__ import annotations

import ctypes
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import connections, edges
from .errors import DescriptionError
from .fmi.model_description import checked_value, clocks_of, is_scheduled, read_fmu, steps_every
from .fmi.slave import C_TYPES, Slave
from .native.loop import NativeLoop
from .observers import Batch, Observer, ReplayStopped, StopRun, replay
from .system import System, faults_from_zero, validate
from .texts import TextLinks

# Which FMUs run in a worker process of their own: a predicate (fmu path, model description) -> bool
IsolationPolicy = Callable[[Path, object], bool]


def _variables(mds: dict) -> dict[str, dict]:
    """{instance: {variable name: variable}}, looked up by _check_parameters (built once an execution)."""
    return {name: {v.name: v for v in md.modelVariables} for name, md in mds.items()}


def _fed(links) -> dict:
    """The inputs connections set every step, by (target, type, value reference)."""
    return {(link.target, link.type, link.target_vr): link for link in links}


def _check_parameters(system: System, variables: dict[str, dict], fed: dict) -> None:
    """Every given value fits its variable, and none is for an input a connection overwrites every step (variables:
    _variables, fed: _fed)."""
    for spec in system.instances:
        variables_of = variables[spec.name]
        for key, value in spec.parameters.items():
            v = variables_of.get(key)
            checked_value(spec.name, v, key, value)
            link = fed.get((spec.name, v.type, v.valueReference)) if v.causality == "input" else None
            if link is not None:
                raise DescriptionError(f"{spec.name}.{key} is an input fed by {link.source}.{link.source_name} every step: "
                                       "setting it has no effect")


@dataclass
class _Group:
    """Links from one source into one target of one type and delay: a gather into an array the set reads, from the
    source's values of source_type (the target's type, or one connections.CONVERSIONS converts from)."""

    source: str
    target: str
    type: str
    delay: int
    source_type: str
    src_index: np.ndarray
    dst_vrs: object  # ctypes array of the target's value references
    values: object  # ctypes array the set reads; `view` is it as numpy
    view: np.ndarray
    setter: object  # the target's raw fmi2Set<type>


class Execution:
    def __init__(self, system: System, observers=(), isolate: IsolationPolicy | None = None,
                 step_timeout: float | None = None, profile: bool = False) -> None:
        """isolate(fmu, md): True for an FMU to run in a worker process of its own, every call watched for
        step_timeout seconds (isolation/process.py); None: every FMU runs in this process. profile: the C loop
        times each FMU's set, doStep and get calls into its fmi_seconds (two clock reads a step; the benchmarks'
        C cost), which a run otherwise does not pay for."""
        self.system = validate(system)
        self.profile = profile
        self.profiler = None  # profile.Profiler while a run is profiled: it times the observers (deliver)
        self.isolate, self.step_timeout = isolate, step_timeout
        self.observers = list(observers)
        self.instances: dict[str, Slave] = {}
        self.time = self.system.start_time  # where it stands until the first tick (a failed initialization's time)
        self.ticks_done = 0
        mds = {i.name: read_fmu(i.fmu, i.name) for i in system.instances}
        self.links = connections.resolve(system, mds)
        loop = edges.algebraic_loop(system, self.links, mds)
        if loop is not None:  # no order of the connected inputs at t = 0 sets each from a final value
            raise DescriptionError(f"algebraic loop: {' -> '.join(loop)} (each output depends directly on the input "
                                   "before it); give one of its connections a delay")
        self._variables, self._fed = _variables(mds), _fed(self.links)  # what every run's parameters are checked against
        _check_parameters(system, self._variables, self._fed)
        self.unconnected = connections.unconnected(system, mds, self.links)  # held for the whole run: said before it starts
        self.tables = {}  # instance -> its input file (inputs.py), applied before each of its steps
        for spec in system.instances:
            if spec.input_file is not None:
                from .inputs import InputTable

                fed = {link.target_name for link in self.links if link.target == spec.name}
                self.tables[spec.name] = InputTable(spec.name, spec.input_file, mds[spec.name], fed)
        self.every = {i.name: steps_every(i, mds[i.name], system.tick) for i in system.instances}  # clocks replace period
        clocked = [name for name, md in mds.items() if clocks_of(md) or is_scheduled(md)]
        if system.start_time and clocked:  # their clock ticks are counted from t = 0 by the master
            raise DescriptionError(f"the system starts at {system.start_time:g} s and {', '.join(clocked)} has clocks, "
                                   "which tiltload ticks from t = 0 only")
        self.texts = TextLinks(self.links)  # String and Binary connections, set in Python (texts.py)
        groups: dict[tuple, list] = {}
        for link in self.links:
            if link.type in connections.TEXTS:
                continue
            groups.setdefault((link.source, link.target, link.type, link.delay, link.source_type), []).append(link)
        self._mds = mds
        self._raw_groups = groups
        self.groups: dict[str, list[_Group]] = {}
        self.max_delay = max((link.delay for link in self.links), default=0)
        self.manipulator = None
        self.loop: NativeLoop | None = None
        self.resumed_at: float | None = None  # the time of the snapshot this run continues from
        self.ended_by: tuple[str, float] | None = None  # (instance, time): an FMU that ended the run
        self._held: dict | None = None  # the outputs at the end of the last batch replayed (deliver)
        if system.faults:
            from .faults.apply import Manipulator

            self.manipulator = Manipulator(system.faults)
            self.manipulator.check(mds, self.links)

    @property
    def model_descriptions(self) -> dict:
        """{instance: model description}, as read before anything was loaded."""
        return self._mds

    def instantiate(self, resume=None) -> None:
        """Load every FMU (in this process, a worker of its own or on the tiltload serve its instance names), bind the
        connections, initialize; with resume (a snapshot.Snapshot of this system), continue from where it was taken."""
        from .isolation.hosting import slave_for

        self.loop = None  # new instances: a new plan
        for spec in self.system.instances:  # on a tiltload serve, in a worker process or in this one (hosting.py)
            self.instances[spec.name] = slave_for(spec, self._mds[spec.name], self.isolate, self.step_timeout, self.system.tick)
        for (src, dst, typ, delay, src_typ), links in self._raw_groups.items():
            idx = np.array([self.instances[src].out_index[src_typ][link.source_vr] for link in links], dtype=int)
            buf = (C_TYPES[typ] * len(links))()
            vrs = (ctypes.c_uint * len(links))(*[link.target_vr for link in links])
            self.groups.setdefault(dst, []).append(_Group(src, dst, typ, delay, src_typ, idx, vrs, buf,
                                                          np.ctypeslib.as_array(buf), self.instances[dst].setters[typ]))
        if self.manipulator is not None:
            self.manipulator.bind(self)
        self._initialize(resume)

    def _initialize(self, resume=None) -> None:
        """Set-up, parameters and initialization of every instance, then the observers start at t = 0 (or where the
        snapshot resume was taken)."""
        from . import snapshot

        order = edges.propagation_order(self.system, self.links) if resume is None else []
        t0 = self.system.start_time
        start = {"start": t0} if t0 else {}  # set up at the system's start time (a slave of its own takes none at 0)
        self.texts.reset()
        for spec in sorted(self.system.instances, key=lambda s: order.index(s.name) if s.name in order else -1):
            inst = self.instances[spec.name]  # the sampled-data instances first, then the others sources first
            parameters = {**spec.parameters, **self.tables[spec.name].values(t0)} if spec.name in self.tables else \
                spec.parameters  # an input file's values at the start are set in Initialization Mode
            if spec.name in order and getattr(inst, "connects_in_initialization", False) and self._connected(spec.name):
                inst.initialize(parameters, connect=lambda name=spec.name: self._connect_initial(name), **start)
                order.remove(spec.name)
            else:
                inst.initialize(parameters, **start)
            if inst.text_outputs:  # what its String and Binary outputs feed at t = 0
                inst.read_texts()
        self.time, self.ticks_done = t0, 0
        self.resumed_at = None
        self.ended_by: tuple[str, float] | None = None  # (instance, time): an FMU that ended the run
        if resume is not None:
            snapshot.restore(self, resume)
            self.resumed_at = resume.time
        else:
            self._propagate(order)
        for inst in self.instances.values():  # String and Binary outputs at t = 0 (the loop reads them after each step)
            if inst.text_outputs:
                inst.read_texts()
        self.texts.start(self.instances, self.ticks_done)
        for obs in self.observers:
            obs.start(self)
        if self.loop is not None and self.loop.reusable():  # a restart on the same instances: the plan stays
            self.loop.restart()
        else:
            # the plan of the C tick loop over these instances, groups and faults; an instance with an input file is
            # stepped through its callback, which sets the file's values first
            self.loop = NativeLoop(self, by_callback=frozenset(self.tables))
        if resume is not None:
            snapshot.restore_loop(self, resume)
            snapshot.restore_observers(self, resume)
        self._held = self._values() if self.stepwise_observers() else None

    def _connected(self, name: str) -> bool:
        """Has the instance connected inputs (numbers, Strings or Binaries)?"""
        return bool(self.groups.get(name)) or name in self.texts.targets

    def _connect_initial(self, name: str) -> None:
        """An instance's connected inputs set from its sources' outputs now (their values at t = 0)."""
        for g in self.groups.get(name, ()):
            g.view[:] = self.instances[g.source].values[g.source_type][g.src_index]  # int32 into float64: exact
        self.set_gathered_inputs(name, 0.0)
        self.texts.set_inputs(self.instances, name, 0)

    def _propagate(self, order: list[str]) -> None:
        """The instances whose outputs are logged at t = 0 (edges.propagation_order) and were not connected in their
        Initialization Mode (an FMU in this process without clocks is: Execution._initialize): their connected inputs
        set after it, their outputs read again (an FMU that computes its outputs when they are read shows the connected
        values at t = 0; an FMU in another process was connected in its Initialization Mode too, its inputs sent with the
        init request). An FMI 3.0 FMU with clocks or discrete connected inputs (settable in Event Mode only) is left as
        initialized."""
        for name in order:
            inst, groups = self.instances[name], self.groups.get(name, ())
            kinds = getattr(inst, "input_kind", {})
            if not self._connected(name) or getattr(inst, "clocked", False) or any(
                    kinds.get((g.type, vr), "continuous") != "continuous" for g in groups for vr in g.dst_vrs):
                continue
            self._connect_initial(name)
            inst.read_outputs()

    def stop_plan(self, stop: float) -> edges.StopPlan:
        """Where a run asked to stop at `stop` ends (edges.stop_plan): its note, if any, is for the user before the run."""
        return edges.stop_plan(stop, self.system.tick, edges.variable_steps(self._mds), self.system.start_time)

    def _values(self) -> dict[str, dict[str, np.ndarray]]:
        """Every instance's output values now (a copy): what a per-step observer sees of an instance that has not
        stepped yet in the batch replayed next."""
        return {name: {typ: v.copy() for typ, v in inst.values.items()} for name, inst in self.instances.items()}

    def restart(self, parameters: dict[str, dict] | None = None, observers=None, faults=None, resume=None) -> None:
        """A new run on the same FMU instances: fmi2Reset, then initialization with these parameters
        ({instance: {name: value}}, replacing the given instances' parameters) and these observers; with resume (a
        snapshot of this system), from where it was taken. Cheaper than instantiating again (campaigns run many
        runs on one set of FMUs per worker)."""
        for name, values in (parameters or {}).items():
            self.system.instance(name).parameters = dict(values)
        _check_parameters(self.system, self._variables, self._fed)
        if observers is not None:
            self.observers = list(observers)
        if faults is not None:  # a new fault schedule (a list, possibly empty)
            from .faults.apply import Manipulator

            faults_from_zero(self.system.start_time, faults)
            self.system.faults = list(faults)
            self.manipulator = Manipulator(self.system.faults) if faults else None
            if self.manipulator is not None:
                self.manipulator.check(self._mds, self.links)
                self.manipulator.bind(self)
        elif self.manipulator is not None:
            self.manipulator = type(self.manipulator)(self.system.faults)  # fresh state: holds, histories
            self.manipulator.bind(self)
        if resume is not None:
            from .snapshot import check

            check(self, resume)
        for spec in self.system.instances:
            self.instances[spec.name].reset()
        self._initialize(resume)

    def set_gathered_inputs(self, name: str, t: float) -> None:
        """Set an instance's connected inputs from its groups' arrays (filled by the tick loop, manipulated already)."""
        inst = self.instances[name]
        component = inst.component
        for g in self.groups.get(name, ()):
            started = time.perf_counter()
            status = g.setter(component, g.dst_vrs, len(g.view), g.values)
            inst.fmi_seconds += time.perf_counter() - started
            if status > 1:
                raise inst.failed(f"set{g.type} from {g.source} at t={t:.6g} s", status)

    def stepwise_observers(self) -> list:
        """The observers of the per-step kind (no on_batch of their own)."""
        return [obs for obs in self.observers if type(obs).on_batch is Observer.on_batch]

    def deliver(self, batch: Batch) -> None:
        """A call's steps to the observers: replayed step by step to those of the per-step kind, then whole to those
        that take batches (cut where a per-step observer stopped the run, so every observer saw the same steps)."""
        stepwise = self.stepwise_observers()
        # one that hands the batch to a thread of its own goes last: the others' Python is done before that thread's
        # starts, which then runs beside the tick loop's next call instead of competing for the interpreter
        batchwise = sorted((obs for obs in self.observers if obs not in stepwise), key=lambda obs: obs.threaded)
        started = time.monotonic_ns() if self.profiler is not None and stepwise else 0
        try:
            self._held = replay(self, batch, stepwise, self._held)
        except ReplayStopped as stop:
            head = batch.head(stop.cut)
            for obs in batchwise:
                self._on_batch(obs, head)
            raise stop.__cause__ from None
        finally:
            if started:
                self.profiler.observe(None, time.monotonic_ns() - started)
        stop = None
        for obs in batchwise:
            try:
                self._on_batch(obs, batch)
            except StopRun as err:  # the others (the log) still take this batch
                stop = stop or err
        if stop is not None:
            raise stop

    def _on_batch(self, obs, batch: Batch) -> None:
        """obs.on_batch(batch), timed for the profile while a run is profiled (profile.py)."""
        if self.profiler is None:
            obs.on_batch(self, batch)
            return
        started = time.monotonic_ns()
        try:
            obs.on_batch(self, batch)
        finally:
            self.profiler.observe(obs, time.monotonic_ns() - started)

    def step_tick(self) -> None:
        """One tick."""
        self.loop.run(1)

    def run(self, stop: float, realtime=None) -> None:
        """Run up to the tick nearest stop (an absolute time, from where the execution is); realtime paces the ticks (realtime.py). Nothing
        once an FMU ended the run (ended_by)."""
        n = int(round((stop - self.system.start_time) / self.system.tick))
        if self.ticks_done < n and self.ended_by is None:
            self.loop.run(n - self.ticks_done, realtime)

    def end(self, stop: float, realtime=None) -> None:
        """The run's last stretch: to the end of stop_plan(stop) (a shorter last step, or the nearest tick), then the
        closing samples there (edges.py); the execution's time is then the run's end."""
        plan = self.stop_plan(stop)
        self.loop.plan.stop_time = plan.end if plan.shortened else 0.0
        try:
            if self.ticks_done < plan.ticks and self.ended_by is None:
                self.loop.run(plan.ticks - self.ticks_done, realtime)
        finally:
            self.loop.plan.stop_time = 0.0
        if self.ticks_done == plan.ticks and self.ended_by is None:
            self.loop.close(plan.end)
            self.time = plan.end

    def finish(self, error: str | None = None) -> None:
        """Finish the observers (the log first: its last chunks and summary written); safe to call twice."""
        observers, self.observers = self.observers, []
        for obs in observers:
            try:
                obs.finish(self, error)
            except Exception:
                pass

    def close(self, error: str | None = None) -> None:
        """Finish the observers, then free the instances; safe to call twice."""
        self.finish(error)
        instances, self.instances = self.instances, {}
        for inst in instances.values():
            inst.close()

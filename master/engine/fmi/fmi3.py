"""An FMI 3.0 co-simulation FMU loaded into this process, with or without clocks, behind the Slave interface.

Without clocks it steps as an FMI 2.0 FMU does: the inputs set, fmi3DoStep(t, h), the outputs read. With
periodic input clocks (which replace the instance's period) it runs the standard's co-simulation sequence
with Event Mode at every step where a clock is due (or the FMU asked for an event):

    fmi3EnterEventMode -> set the inputs -> fmi3SetClock(the due clocks) -> set their clocked inputs
    -> get their clocked outputs -> fmi3UpdateDiscreteStates until no further update -> fmi3EnterStepMode
    -> fmi3DoStep(t, h) -> get the outputs that are not clocked

The clocked outputs are read before fmi3UpdateDiscreteStates, which deactivates the clocks (a clocked variable
is accessible only while its clock is active), and hold their values until the clock's next tick. A clock of
interval n ticks and shift s ticks is due at tick k when k >= s and (k - s) % n == 0; the first tick (shift 0)
is the Event Mode that follows fmi3ExitInitializationMode. The setters the execution calls stage the values:
they reach the FMU in the Step Mode before the step (continuous inputs) or in the Event Mode (discrete and
clocked ones; a discrete input that changed makes the step an event). `activations` records every clock tick.

In this process the C tick loop (native/tl_loop.c) calls its fmi3 functions itself, as it calls an FMI 2.0 FMU's
fmi2 ones: without clocks set, fmi3DoStep, get; with clocks the sequence above too, planned from this slave
(native/clocks.py: its schedule, input kinds and output reads, the held clocked outputs in this slave's buffers,
event_state handed over around each call). do_step here is the sequence for a host process (isolation/worker.py),
where the slave is stepped from Python. A snapshot's bytes (get_state) carry the FMU's
own serialized state and what this slave holds besides: the clocked outputs as read at their last ticks and a
pending event (fmi3_state.py).
"""

from __future__ import annotations

import ctypes
import time
from pathlib import Path

import numpy as np
from fmpy.fmi3 import FMU3Slave

from ..errors import ExecutionError, FmuEndedRun
from .binding import Binding, c_function
from .fmi3_inputs import API, FMI3_NAME, StagedInputs, api_type
from .fmi3_state import Fmu3State
from .model_description import EXACT, FMI_TYPES, clock_ticks, clocks_of, fmi_type
from .slave import TYPES

MAX_EVENT_ITERATIONS = 100


class Fmu3Slave(Binding):
    """One instantiated FMI 3.0 co-simulation FMU in this process; tick: the execution's, to place the clock ticks."""

    PARAMETER_SETTERS = {name: f"set{API.get(name, name)}" for name in FMI_TYPES}

    def __init__(self, name: str, path: Path, md, tick: float | None = None) -> None:
        super().__init__(name, path, md)
        self.clocks = clocks_of(md)
        self.clocked = bool(self.clocks)
        self.tick = tick
        if self.clocked and tick is None:
            raise ExecutionError(f"{name}: an FMU with clocks needs the execution's tick")
        ticks = clock_ticks(md, tick, name) if self.clocked else {}
        self.schedule = [(j, k, *ticks[k.name]) for j, k in enumerate(self.clocks)]  # (index, clock, n, s)
        self.activations: dict[str, list[int]] = {k.name: [] for k in self.clocks}  # clock -> the ticks it was activated
        self.input_kind = {}
        # (carrier, value reference) -> the FMI 3.0 function type, for the variables whose type is not their carrier's
        self.api = {(v.type, v.valueReference): API[fmi_type(v)] for v in md.modelVariables
                    if v.causality in ("input", "output") and v.type in TYPES and API[fmi_type(v)] != FMI3_NAME[v.type]}
        self._clocked_outputs: dict[int, list] = {}
        by_name = {k.name: j for j, k in enumerate(self.clocks)}
        for v in md.modelVariables:
            clock = next((by_name[c.name] for c in (v.clocks or ()) if c.name in by_name), None)
            if v.causality == "input" and v.type in TYPES:
                kind = clock if clock is not None else ("discrete" if v.variability == "discrete" else "continuous")
                self.input_kind[(v.type, v.valueReference)] = kind

        def log_message(env, status, category, message):
            self.log.append(message.decode("utf-8", "replace"))
        self._log_message = log_message
        self.fmu = self._instantiate(md, name)
        self._bind()

    # ---- set-up ---------------------------------------------------------------------------------------------
    def _instantiate(self, md, name: str):
        """FMPy's object for this FMU, instantiated for co-simulation (the Scheduled Execution slave overrides it)."""
        return self._load(
            lambda folder: FMU3Slave(guid=md.guid, unzipDirectory=folder, modelIdentifier=md.coSimulation.modelIdentifier,
                                     instanceName=name),
            lambda fmu: fmu.instantiate(loggingOn=True, eventModeUsed=self.clocked, logMessage=self._log_message))

    def _bind(self) -> None:
        dll = self.fmu.dll
        self.component = self.fmu.component
        self._raw = {}  # (Get or Set, FMI 3.0 type): the FMU's function; the carriers' own under their names too
        for api in {*FMI3_NAME.values(), *self.api.values()}:
            for kind in ("Get", "Set"):
                self._raw[kind, api] = c_function(dll, f"fmi3{kind}{api}",
                                                  [ctypes.c_void_p, ctypes.POINTER(ctypes.c_uint), ctypes.c_size_t,
                                                   ctypes.POINTER(FMI_TYPES[api].c_type), ctypes.c_size_t])
        for t, api in FMI3_NAME.items():
            for kind in ("Get", "Set"):
                self._raw[kind, t] = self._raw[kind, api]
        self._do_step = c_function(dll, "fmi3DoStep", [ctypes.c_void_p, ctypes.c_double, ctypes.c_double, ctypes.c_bool,
                                                       *([ctypes.POINTER(ctypes.c_bool)] * 3), ctypes.POINTER(ctypes.c_double)])
        self._step_out = (ctypes.c_bool(), ctypes.c_bool(), ctypes.c_bool(), ctypes.c_double())
        self._step_refs = tuple(ctypes.byref(x) for x in self._step_out)
        for fn in ("fmi3EnterEventMode", "fmi3EnterStepMode"):
            c_function(dll, fn, [ctypes.c_void_p])
        c_function(dll, "fmi3SetClock", [ctypes.c_void_p, ctypes.POINTER(ctypes.c_uint), ctypes.c_size_t,
                                         ctypes.POINTER(ctypes.c_bool)])
        c_function(dll, "fmi3UpdateDiscreteStates", [ctypes.c_void_p, *([ctypes.POINTER(ctypes.c_bool)] * 5),
                                                     ctypes.POINTER(ctypes.c_double)])
        self._update_out = (*(ctypes.c_bool() for _ in range(5)), ctypes.c_double())
        self._update_refs = tuple(ctypes.byref(x) for x in self._update_out)
        # outputs: values[type] in model-description order; the clocked ones read in Event Mode, the rest after a step
        clock_of = {}
        by_name = {k.name: j for j, k in enumerate(self.clocks)}
        for t in TYPES:
            for v in self.outputs[t]:
                clock_of[t, v.valueReference] = next((by_name[c.name] for c in (v.clocks or ()) if c.name in by_name), None)
        self._reads, self._clocked_outputs = [], {}
        self._wide: dict[int, str] = {}  # id of a read of 64-bit integers -> its type: a double holds them within 2^53
        for t in TYPES:
            n = len(self.out_vrs[t])
            self.values[t] = np.zeros(n, dtype=np.float64 if t == "Real" else np.int32)
            self.setters[t] = self._setter(t)
            groups: dict[tuple, list[int]] = {}
            for i, vr in enumerate(self.out_vrs[t]):
                groups.setdefault((clock_of[t, vr], api_type(self, t, vr)), []).append(i)
            for (clock, api), idx in groups.items():
                buf = (FMI_TYPES[api].c_type * len(idx))()
                entry = (self._raw["Get", api], self.values[t], (ctypes.c_uint * len(idx))(*[self.out_vrs[t][i] for i in idx]),
                         len(idx), buf, np.ctypeslib.as_array(buf), np.array(idx) if len(idx) < n else slice(None))
                if api in ("Int64", "UInt64"):
                    self._wide[id(entry)] = api
                if clock is None:
                    self._reads.append(entry)
                else:
                    self._clocked_outputs.setdefault(clock, []).append(entry)
        self._held = [e for entries in self._clocked_outputs.values() for e in entries]
        self._staged: dict[int, StagedInputs] = {}
        self._converted: dict[int, StagedInputs] = {}  # set at once, converted (set_converted)
        self._discrete_inputs: list[StagedInputs] = []
        self._clock_calls: dict[tuple[int, ...], tuple] = {}  # due clocks -> the arrays of their fmi3SetClock
        self._in_event = False  # the Event Mode right after initialization is the first tick's
        self._event_asked = False  # the FMU asked for an event at the next step (a time event it reached)
        self._next_event: float | None = None

    def _setter(self, t: str):
        """The execution's setter for type t (fmi2Set<type> signature). Without clocks it sets the values at once (in
        Step Mode, as the C loop's own calls do); with clocks it stages them for the next step, which sets each kind
        when the standard allows (Event Mode for the discrete and clocked ones)."""
        if not self.clocked and not any(key[0] == t for key in self.api):
            raw = self._raw["Set", t]

            def set_now(component, vrs, n, values) -> int:
                started = time.perf_counter()
                if t == "Boolean":  # fmi3Boolean is a C bool, the execution's Booleans are int
                    values = (ctypes.c_bool * n)(*[bool(x) for x in values[:n]])
                status = raw(component, vrs, n, values, n)
                self.fmi_seconds += time.perf_counter() - started
                return status
            return set_now
        if not self.clocked:  # inputs of other FMI 3.0 types than the carrier's: each part converted and set at once
            def set_converted(component, vrs, n, values) -> int:
                key = ctypes.addressof(vrs)
                entry = self._converted.get(key)
                if entry is None:
                    entry = self._converted[key] = StagedInputs(self, t, vrs, n)
                entry.stage(values)
                try:
                    self._set_parts(entry, None, None)
                except ExecutionError:
                    return 3
                return 0
            return set_converted

        def stage(component, vrs, n, values) -> int:
            entry = self._staged.get(ctypes.addressof(vrs))
            if entry is None:
                entry = self._staged[ctypes.addressof(vrs)] = StagedInputs(self, t, vrs, n)
                self._discrete_inputs = [e for e in self._staged.values() if e.discrete]
            entry.stage(values)
            return 0
        return stage

    # ---- the C tick loop's view of a clocked FMU (native/clocks.py) -------------------------------------------
    def output_reads(self) -> list[tuple]:
        """Every read of outputs: (clock index, None for the outputs of no clock; type; value references; n; the
        buffer in the FMU's type, which holds a clock's outputs between its ticks; indices into values[type])."""
        by_values = {id(v): t for t, v in self.values.items()}
        groups = [(None, self._reads), *self._clocked_outputs.items()]
        return [(clock, by_values[id(out)], vrs, n, buf, idx) for clock, es in groups for _, out, vrs, n, buf, _, idx in es]

    @property
    def event_state(self) -> tuple[bool, bool, float | None]:
        """Between two steps: in the Event Mode after initialization, an event asked for, the next event time."""
        return self._in_event, self._event_asked, self._next_event

    @event_state.setter
    def event_state(self, state: tuple[bool, bool, float | None]) -> None:
        self._in_event, self._event_asked, self._next_event = state

    # ---- calls -----------------------------------------------------------------------------------------------
    def _check(self, status: int, what: str, t: float) -> None:
        if status > 1:
            raise self.failed(f"{what} at t={t:.6g} s", status)

    @property
    def connects_in_initialization(self) -> bool:
        """The master may set its connected inputs in Initialization Mode (initialize's connect): without clocks."""
        return not self.clocked

    def initialize(self, parameters: dict, connect=None, start: float = 0.0) -> None:
        """connect(): the master sets the connected inputs in Initialization Mode (engine/edges.py; not with clocks).
        start: the system's start time."""
        self.call("enterInitializationMode", lambda: self.fmu.enterInitializationMode(startTime=float(start)))
        self.set_parameters(parameters)
        if connect is not None and not self.clocked:
            connect()
        if self.clocked:  # clocked outputs are accessible at initialization, not in Event Mode before their clock ticks
            self._read(self._reads + [e for es in self._clocked_outputs.values() for e in es], "get at initialization")
        self.call("exitInitializationMode", self.fmu.exitInitializationMode)
        self._in_event = self.clocked
        self._event_asked, self._next_event = False, None
        for a in self.activations.values():
            a.clear()
        if not self.clocked:
            self.read_outputs()

    def reset(self) -> None:
        self.call("reset", self.fmu.reset)
        self._staged.clear()
        self._discrete_inputs = []

    def _set(self, kinds, t: float) -> None:
        """Set the staged inputs whose kind is in kinds (a set of "continuous", "discrete", clock indices)."""
        for entry in self._staged.values():
            self._set_parts(entry, kinds, t)

    def _set_parts(self, entry: StagedInputs, kinds, t: float | None) -> None:
        """Set an entry's parts of those kinds (None: all), each converted to its FMI 3.0 type."""
        started = time.perf_counter()
        for kind, vrs, n, buf, view, idx, api in entry.parts:
            if kinds is not None and kind not in kinds:
                continue
            if idx is not None:
                view[:] = entry.staged[idx]
            status = self._raw["Set", api](self.component, vrs, n, buf, n)
            if status > 1:
                self.fmi_seconds += time.perf_counter() - started
                raise self.failed(f"set{api}" + ("" if t is None else f" at t={t:.6g} s"), status)
            if kind == "discrete":
                entry.applied[id(vrs)] = view.copy()
        self.fmi_seconds += time.perf_counter() - started

    def _read(self, entries, what: str, t: float | None = None) -> None:
        started = time.perf_counter()
        component = self.component
        for entry in entries:
            get, out, vrs, n, buf, view, idx = entry
            status = get(component, vrs, n, buf, n)
            if status > 1:
                self.fmi_seconds += time.perf_counter() - started
                raise self.failed(what if t is None else f"{what} at t={t:.6g} s", status)
            if self._wide and id(entry) in self._wide and n and np.abs(view.astype(np.float64)).max() > EXACT:
                name = next(v.name for v in self.outputs["Real"] if v.valueReference == vrs[int(np.argmax(
                    np.abs(view.astype(np.float64))))])
                raise ExecutionError(f"{self.name}: {self._wide[id(entry)]} output {name} = "
                                     f"{view[np.argmax(np.abs(view.astype(np.float64)))]} is beyond +-2^53, which the "
                                     "engine carries exactly")
            out[idx] = view
        self.fmi_seconds += time.perf_counter() - started

    @property
    def kernel_types(self) -> bool:
        """Are its connected and logged variables all of the types the C tick loop gets and sets itself (Float64,
        Int32, Boolean)? Otherwise the loop steps it through its Python callback, which converts."""
        return not self.api

    # ---- a step -------------------------------------------------------------------------------------------------
    def _due(self, k: int) -> list[int]:
        return [j for j, _, n, s in self.schedule if k >= s and (k - s) % n == 0]

    def _event(self, t: float, k: int, due: list[int]) -> None:
        dll = self.fmu.dll
        if not self._in_event:
            self._check(dll.fmi3EnterEventMode(self.component), "enterEventMode", t)
        self._set({"continuous", "discrete"}, t)
        if due:
            key = tuple(due)
            call = self._clock_calls.get(key)
            if call is None:
                n = len(due)
                call = self._clock_calls[key] = ((ctypes.c_uint * n)(*[self.clocks[j].value_reference for j in due]), n,
                                                 (ctypes.c_bool * n)(*([True] * n)), set(due),
                                                 [e for j in due for e in self._clocked_outputs.get(j, ())])
            vrs, n, on, kinds, outputs = call
            self._check(dll.fmi3SetClock(self.component, vrs, n, on), "setClock", t)
            self._set(kinds, t)
            for j in due:
                self.activations[self.clocks[j].name].append(k)
            self._read(outputs, "get clocked outputs", t)
        need, terminate, _, _, next_defined, next_time = self._update_out
        for _ in range(MAX_EVENT_ITERATIONS):
            self._check(dll.fmi3UpdateDiscreteStates(self.component, *self._update_refs), "updateDiscreteStates", t)
            if terminate.value:
                raise ExecutionError(f"{self.name}: the FMU asked to terminate the simulation at t={t:.6g} s")
            if not need.value:
                break
        else:
            raise ExecutionError(f"{self.name}: its discrete states still needed an update after {MAX_EVENT_ITERATIONS} "
                                 f"iterations at t={t:.6g} s")
        self._next_event = next_time.value if next_defined.value else None
        self._check(dll.fmi3EnterStepMode(self.component), "enterStepMode", t)
        self._in_event = False

    def do_step(self, t: float, h: float) -> None:
        if self.clocked:
            k = round(t / self.tick)
            due = self._due(k)
            reached = self._next_event is not None and t >= self._next_event - 1e-9 * h
            if self._in_event or due or self._event_asked or reached or any(e.changed_discrete() for e in self._discrete_inputs):
                self._event_asked = False
                self._event(t, k, due)
            else:
                self._set({"continuous"}, t)
        else:
            self._set({"continuous", "discrete"}, t)
        started = time.perf_counter()
        status = self._do_step(self.component, t, h, True, *self._step_refs)
        self.fmi_seconds += time.perf_counter() - started
        if status > 1:
            raise self.failed(f"doStep at t={t:.6g} s", status)
        event_needed, terminate, early, last = self._step_out
        self._event_asked = bool(event_needed.value)
        if terminate.value:  # the run ends at the step's end (or where it returned early), as FMPy's
            raise FmuEndedRun(self.name, last.value if early.value and last.value < t + h else t + h)

    def read_outputs(self) -> None:
        """The outputs after a step: those not clocked from the FMU, the clocked ones as read at their clock's last
        tick (again each step: what an observer or a fault did to values since is not the FMU's)."""
        self._read(self._reads, "get")
        for _, out, _, _, _, view, idx in self._held:
            out[idx] = view

    def save_state(self) -> Fmu3State:
        """Between two steps: everything a new instance of this FMU needs to continue (restore_state)."""
        state = self.call("getFMUState", self.fmu.getFMUState)
        try:
            blob = self.call("serializeFMUState", lambda: self.fmu.serializeFMUState(state))
        finally:
            self.call("freeFMUState", lambda: self.fmu.freeFMUState(state))
        return Fmu3State(blob, {t: v.copy() for t, v in self.values.items()}, [e[5].copy() for e in self._held],
                         self._event_asked, self._next_event)

    def restore_state(self, saved: Fmu3State) -> None:
        """Continue from a state save_state took (of this FMU, in any instance), in place of initialize."""
        state = self.call("deserializeFMUState", lambda: self.fmu.deserializeFMUState(saved.fmu))
        try:
            self.call("setFMUState", lambda: self.fmu.setFMUState(state))
        finally:
            self.call("freeFMUState", lambda: self.fmu.freeFMUState(state))
        for t, v in saved.values.items():
            self.values[t][:] = v
        for entry, held in zip(self._held, saved.held):
            entry[5][:] = held
        self._in_event, self._event_asked, self._next_event = False, saved.event_asked, saved.next_event

    def get_state(self) -> bytes:
        """save_state as bytes, for a snapshot (which keeps values itself)."""
        return self.save_state().to_bytes()

    def set_state(self, state: bytes) -> None:
        """Restore what get_state gave (of this FMU): the FMU's state, the held clocked outputs, a pending event;
        the outputs follow (the held ones as held, the others read from the FMU)."""
        saved = Fmu3State.from_bytes(state, self.name)
        if len(saved.held) != len(self._held) or any(h.size != e[5].size for h, e in zip(saved.held, self._held)):
            raise ExecutionError(f"{self.name}: cannot restore its state: it holds other clocked outputs than this FMU")
        self.restore_state(saved)
        self.read_outputs()

"""The execution's plan for the C tick loop (tl_loop.c), and the runs of it.

The plan points at the arrays the engine already has: each slave's output arrays (which fmi2Get
fills), each connection group's value-reference and value arrays, the delay line; so Python and C
read and write the same memory, and a manipulator (a fault) that the kernel calls back acts on the
same values it did when Python stepped. An FMU in this process the kernel calls itself: FMI 2.0 through its fmi2
functions, FMI 3.0 co-simulation through its fmi3 ones, with clocks through Event Mode as well (clocks.py plans it),
and a Scheduled Execution FMU as the scheduler of its partitions (the same plan, with their rank order).
The Python callback steps a slave hosted elsewhere (a worker process of its own, a `tiltload serve`: its calls are
messages to its host, where the in-process slave runs them). `paths` says which each instance takes.
After each call the kernel's records of every step are handed to the observers as one Batch. The faults' part of the
plan: fault_plan.py.
"""

from __future__ import annotations

import ctypes

import numpy as np

from ..errors import FmuEndedRun
from ..fmi.fmi2 import InProcessFmu
from ..fmi.fmi3 import FMI3_NAME
from ..fmi.slave import TYPES
from ..observers import Batch
from . import kernel
from .clocks import ClockedPlan
from .codes import Dimension, ErrorKind, Profile, Side, value_type
from .failures import kernel_error
from .fault_plan import SIDES, FaultPlan
from .links import SharedMemoryLinks
from .paths import kernel_calls_fmi3, path_of

BUCKETS = int(Dimension.PROFILE_BUCKETS)  # a profile histogram's (profile.py)
INT64_MAX = np.iinfo(np.int64).max

_NO_ERROR = int(ErrorKind.NONE)  # looked at after every call of the loop (a tick's, for per-step observers): a plain int
_SIDE_NAME = {int(code): name for name, code in SIDES.items()}  # per hook call: a plain int key, no enum compared
CHUNK = 256  # ticks per call: ~3 s of a 12 ms loop, a few ms of wall time between two looks at signals and observers
REALTIME_BATCH = 0.25  # s of wall time between two batches of a paced run
_DTYPE = {"Real": np.float64, "Integer": np.int32, "Boolean": np.int32}


class _EventQueue:
    """Stands for the observers while the kernel runs: fault events wait, with their place among the steps (the
    record they precede, and the side of the step)."""

    def __init__(self, plan) -> None:
        self.plan, self.events, self.side = plan, [], Side.INPUTS

    def on_fault(self, t, fault, what) -> None:
        self.events.append((int(self.plan.records), self.side, t, fault, what))


def _address(array) -> int:
    return ctypes.cast(array, ctypes.c_void_p).value if not isinstance(array, np.ndarray) else array.ctypes.data


class NativeLoop(SharedMemoryLinks, FaultPlan):
    """The plan of one execution and its runs; kept when the execution restarts on the same instances (restart()).
    by_callback: instances to step through the Python callback although the kernel could call them (to hold the two
    paths side by side)."""

    def __init__(self, execution, chunk: int = CHUNK, by_callback=frozenset()) -> None:
        self.lib = kernel.library()
        self.ex = execution
        self.chunk = chunk
        self.by_callback = frozenset(by_callback)
        specs = execution.system.instances
        self.names = [s.name for s in specs]
        self.slaves = [execution.instances[n] for n in self.names]
        index = {n: i for i, n in enumerate(self.names)}
        n = len(specs)
        self._keep = []  # everything the plan points into lives as long as the plan
        self.instances = (kernel.Instance * n)()
        self.slots = execution.max_delay + 1 if execution.max_delay else 0
        self.history: list[dict[str, np.ndarray]] = []
        self.records: list[dict[str, np.ndarray]] = []
        self.paths: dict[str, str] = {}  # instance -> how the loop steps it (path_of)
        self.clocked: list[ClockedPlan] = []
        manipulator = execution.manipulator
        for i, spec in enumerate(specs):
            slave, c = self.slaves[i], self.instances[i]
            c.every = execution.every[spec.name]
            c.continuous = spec.timing == "continuous"
            # String and Binary outputs read, and inputs set, in Python (texts.py)
            texts = bool(slave.text_outputs) or spec.name in execution.texts.targets
            forced = spec.name in by_callback or texts
            fmi3 = kernel_calls_fmi3(slave) and not forced
            c.by_callback = forced or not (isinstance(slave, InProcessFmu) or fmi3)
            c.fmi3 = fmi3
            path = path_of(slave)
            self.paths[spec.name] = "callback: asked for" if spec.name in by_callback else \
                "callback: String or Binary variables" if texts and path.startswith("kernel") else path
            if isinstance(slave, InProcessFmu):
                c.component = slave.component
                c.do_step = slave.function_pointer("fmi2DoStep")
                c.boolean_status = slave.function_pointer("fmi2GetBooleanStatus")  # asked after fmi2Discard only
                c.real_status = slave.function_pointer("fmi2GetRealStatus")
            elif fmi3:
                c.component = slave.component
                if not getattr(slave, "scheduled", False):  # no fmi3DoStep in Scheduled Execution
                    c.do_step3 = slave.function_pointer("fmi3DoStep")

            history, record = {}, {}
            for typ in TYPES:
                t = value_type(typ)
                values = slave.values[typ]
                c.n_out[t] = values.size
                c.out[t] = values.ctypes.data
                vrs = (ctypes.c_uint * max(values.size, 1))(*slave.out_vrs[typ])
                self._keep.append(vrs)
                c.out_vrs[t] = _address(vrs)
                if isinstance(slave, InProcessFmu):
                    c.set[t] = slave.function_pointer(f"fmi2Set{typ}")
                    c.get[t] = slave.function_pointer(f"fmi2Get{typ}")
                elif fmi3:
                    c.set3[t] = slave.function_pointer(f"fmi3Set{FMI3_NAME[typ]}")
                    c.get3[t] = slave.function_pointer(f"fmi3Get{FMI3_NAME[typ]}")
                if self.slots:
                    history[typ] = np.zeros((self.slots, values.size), dtype=_DTYPE[typ])
                    c.history[t] = history[typ].ctypes.data
                record[typ] = np.zeros((chunk, values.size), dtype=_DTYPE[typ])
                c.record[t] = record[typ].ctypes.data
            self.history.append(history)
            self.records.append(record)
            groups = execution.groups.get(spec.name, [])
            c_groups = (kernel.Group * max(len(groups), 1))()
            for g, group in zip(c_groups, groups):
                src_index = np.ascontiguousarray(group.src_index, dtype=np.int64)
                self._keep.append(src_index)
                g.source, g.type, g.delay, g.n = index[group.source], value_type(group.type), group.delay, len(group.view)
                g.source_type = value_type(group.source_type)
                g.src_index, g.dst_vrs, g.values = src_index.ctypes.data, _address(group.dst_vrs), _address(group.values)
            self._keep.append(c_groups)
            c.n_groups, c.groups = len(groups), c_groups
            if fmi3:  # fmi3Boolean is a C bool: the kernel converts through this buffer
                room = max([slave.values["Boolean"].size, *(len(g.view) for g in groups if g.type == "Boolean"), 1])
                booleans = (ctypes.c_bool * room)()
                self._keep.append(booleans)
                c.booleans = _address(booleans)
            if fmi3 and slave.clocked:
                self.clocked.append(ClockedPlan(slave, groups, chunk))
                c.clocks = ctypes.pointer(self.clocked[-1].c)
        self.record_instance = np.zeros(chunk * n, dtype=np.int32)
        self.record_tick = np.zeros(chunk * n, dtype=np.int64)
        self.record_time = np.zeros(chunk * n, dtype=np.float64)
        self.record_row = np.zeros(chunk * n, dtype=np.int64)
        self.rows = np.zeros(n, dtype=np.int64)
        # the profile's (profile.py): kept always (5 kB an instance), written by the kernel only with the profile on
        self.histograms = np.zeros((n, BUCKETS), dtype=np.int64)
        self.tick_histogram = np.zeros(BUCKETS, dtype=np.int64)
        self.step_ns = np.zeros(n, dtype=np.int64)
        self.host_ns = np.zeros(n, dtype=np.int64)
        for i, c in enumerate(self.instances):
            c.histogram = self.histograms[i].ctypes.data
        self.lateness = np.zeros(chunk, dtype=np.float64)
        self.overrun = np.zeros(chunk, dtype=np.int8)
        self.plan = kernel.Plan(n_instances=n, instances=self.instances, tick=execution.system.tick,
                                start_time=execution.system.start_time, ticks_done=execution.ticks_done, slots=self.slots,
                                profile=Profile(int(execution.profile)), record_capacity=chunk)
        self.plan.ends_allowed = int(execution.system.fmu_end == "end")
        self._index = index
        self._bound = self._binding()
        self._plan_faults(manipulator)
        self._bind_links()
        self.plan.tick_histogram = self.tick_histogram.ctypes.data
        for name in ("record_instance", "record_tick", "record_time", "record_row", "rows"):
            setattr(self.plan, name, getattr(self, name).ctypes.data)
        self._pending: BaseException | None = None
        self.texts: dict[str, dict[int, dict]] = {}  # this call's String and Binary outputs: name -> {row: values}
        self._queue = _EventQueue(self.plan)
        self.plan.step_callback = kernel.STEP_CALLBACK(self._step)
        self.plan.hook_callback = kernel.HOOK_CALLBACK(self._hook)
        self.lib.tl_store_history(ctypes.byref(self.plan), 0)  # the delay line starts with the values at t = 0

    def _binding(self) -> list:
        """What the plan points into that a restart could change: the instances, their components and output arrays
        (the same array object holds the same memory)."""
        return [(s, s.component, *(s.values[t] for t in TYPES)) for s in self.slaves]

    def reusable(self) -> bool:
        """Can the execution's next run use this plan (restart()) rather than a new one: the same instances, bound to
        the same arrays, nothing stepped by the callback on request, as many instances."""
        if self.by_callback or [s.name for s in self.ex.system.instances] != self.names or \
                any(self.ex.instances.get(n) is not s for n, s in zip(self.names, self.slaves)):
            return False
        return all(a[1] == b[1] and all(x is y for x, y in zip(a[2:], b[2:])) for a, b in zip(self._binding(), self._bound))

    # --- callbacks: Python work the kernel asks for in the middle of a tick -----------------------------------------
    def _step(self, i: int, t: float, h: float) -> int:
        """A slave the kernel cannot call: set its inputs (gathered by the kernel), step it, read its outputs."""
        try:
            slave, name = self.slaves[i], self.names[i]
            table = self.ex.tables.get(name)
            if table is not None:  # its input file's values at the step's start (inputs.py)
                slave.set_values(table.values(t))
            if name in self.ex.texts.targets:  # its String and Binary inputs (texts.py)
                self.ex.texts.set_inputs(self.ex.instances, name, int(self.plan.ticks_done))
            self.ex.set_gathered_inputs(name, t)
            try:
                slave.do_step(t, h)
            except FmuEndedRun as end:  # not a failure: its outputs there are its last valid ones (edges.py)
                if not self.plan.ends_allowed:
                    raise end.failure from None
                slave.read_outputs()
                self._read_texts(i, slave)
                self.plan.ended_time = end.time
                return 2
            slave.read_outputs()
            self._read_texts(i, slave)
            return 0
        except BaseException as err:  # a failure, or Ctrl-C arriving while Python runs: the kernel stops, we re-raise
            self._pending = err
            return 1

    def _read_texts(self, i: int, slave) -> None:
        """An instance's String and Binary outputs after its step, kept for the record the kernel writes next (its row)."""
        if slave.text_outputs:
            slave.read_texts()
            self.texts.setdefault(self.names[i], {})[int(self.rows[i])] = dict(slave.texts)
            self.ex.texts.record(self.names[i], int(self.plan.ticks_done), slave.texts)

    def _hook(self, i: int, side: int, t: float) -> int:
        try:
            self._queue.side = side
            self.ex.manipulator.apply(self.names[i], _SIDE_NAME[side], t, [self._queue])
            return 0
        except BaseException as err:
            self._pending = err
            return 1

    # --- runs ---------------------------------------------------------------------------------------------------------
    def restart(self) -> None:
        """After the execution's instances were reset and initialized (reusable()): the plan as a new one would be,
        without building it again (tables, buffers, function pointers: a campaign's runs differ in parameters and
        faults only). Tick 0, the delay line at its start, no pacing, the faults of the execution's manipulator."""
        p = self.plan
        p.ticks_done, p.profile = self.ex.ticks_done, Profile(int(self.ex.profile))
        p.realtime_factor, p.realtime_start_ns, p.realtime_first_tick, p.lateness, p.overrun = 0.0, 0, 0, None, None
        self._pending = None
        for history in self.history:
            for array in history.values():
                array[:] = 0
        if self._faulted or self.ex.manipulator is not None:
            self._plan_faults(self.ex.manipulator)
        self._bind_links()
        self.lib.tl_store_history(ctypes.byref(p), 0)  # the delay line starts with the values at t = 0
        for clocked in self.clocked:
            clocked.forget_inputs()

    def run(self, ticks: int, realtime=None) -> None:
        """Run the given number of ticks, handing every call's steps to the observers; raise a run's failure."""
        # an observer of the per-step kind gets every tick as it happens (a batch of one), as it would from a Python loop
        chunk = 1 if self.ex.stepwise_observers() else self.chunk
        if realtime is not None:  # paced: the observers hear from the loop about four times a (wall) second
            chunk = min(chunk, max(1, round(REALTIME_BATCH * realtime.factor / self.ex.system.tick)))
        while ticks > 0:
            n = min(ticks, chunk)
            first = int(self.plan.ticks_done)
            if realtime is not None:
                realtime.prepare(self.plan, first, self.lateness, self.overrun)
            self._queue.events = []
            self.texts = {}
            for clocked in self.clocked:
                clocked.push()
            if self._links:
                self._take_links()
            with self._signals_stop_the_wait():
                done = int(self.lib.tl_run(ctypes.byref(self.plan), n))
            for clocked in self.clocked:
                clocked.pull()
            for i, (slave, c) in enumerate(zip(self.slaves, self.instances)):
                if not c.by_callback:  # one stepped by the callback times its own calls
                    slave.fmi_seconds += c.seconds
                self.step_ns[i] += round(c.seconds * 1e9)
                c.seconds = 0.0
            self.ex.ticks_done = int(self.plan.ticks_done)
            self.ex.time = self.ex.system.start_time + self.ex.ticks_done * self.ex.system.tick
            failure = kernel_error(self) if self.plan.error_kind != _NO_ERROR else None
            ended = int(self.plan.ended_instance)
            batch = self._batch(first, done)
            if ended >= 0:  # an FMU ended the run: its step's records are the run's last (edges.py)
                self.ex.ended_by = (self.names[ended], float(self.plan.ended_time))
                batch.closing = True
            try:
                self.ex.deliver(batch)
            except Exception as err:
                if failure is not None:  # an observer tripping on the failed call's partial batch: the run's failure is the cause
                    raise failure from err
                raise
            if failure is not None:
                raise failure
            if ended >= 0:
                self.ex.time = self.ex.ended_by[1]
                return
            if realtime is not None:
                realtime.took(self.lateness[:done], self.overrun[:done], self.ex.system.tick, self.ex.ticks_done,
                              self.ex.system.start_time)
            ticks -= done

    def close(self, t: float) -> None:
        """The run's closing samples at its end t (tl_close; edges.py), handed to the observers as a closing batch."""
        self._queue.events = []
        self.texts = {}
        for clocked in self.clocked:
            clocked.push()
        if self._links:
            self._take_links()
        with self._signals_stop_the_wait():
            failed = int(self.lib.tl_close(ctypes.byref(self.plan), t))
        for clocked in self.clocked:
            clocked.pull()
        failure = kernel_error(self) if failed else None
        batch = self._batch(int(self.plan.ticks_done), 0)
        batch.closing = True
        try:
            self.ex.deliver(batch)
        except Exception as err:
            if failure is not None:
                raise failure from err
            raise
        if failure is not None:
            raise failure

    def profile_from_now(self) -> None:
        """The profile on (wall time), its histograms and sums from zero (profile.Profiler)."""
        p = self.plan
        p.profile = Profile.WALL
        for array in (self.histograms, self.tick_histogram, self.step_ns, self.host_ns):
            array[...] = 0
        p.tick_ns, p.fastest_tick_ns, p.slowest_tick_ns = 0, INT64_MAX, 0
        for c in self.instances:
            c.seconds, c.fastest_ns, c.slowest_ns, c.host_ns = 0.0, INT64_MAX, 0, 0

    def profile_off(self) -> None:
        self.plan.profile = Profile(int(self.ex.profile))
        for i, c in enumerate(self.instances):
            self.host_ns[i] = c.host_ns

    def _batch(self, first: int, done: int) -> Batch:
        r = int(self.plan.records)
        rows = {name: {typ: rec[typ][:int(self.rows[i])] for typ in TYPES} for i, (name, rec) in enumerate(zip(self.names, self.records))}
        events = list(self._queue.events)
        m = self.ex.manipulator
        for e in range(int(self.plan.events)):  # the kernel's fault events, merged in their places
            k = int(self.event_fault[e])
            events.append((int(self.event_record[e]), self._report_side[k], float(self.event_time[e]), m.faults[k],
                           "start" if self.event_start[e] else "end"))
        if self.plan.events:  # as the manipulator alone would tell them: by step, side, then place in the schedule
            place = {id(f): k for k, f in enumerate(m.faults)}
            events.sort(key=lambda ev: (ev[0], ev[1], place[id(ev[3])]))
        return Batch(first, done, self.names, self.record_instance[:r], self.record_tick[:r], self.record_time[:r],
                     self.record_row[:r], rows, [(record, t, f, what) for record, _, t, f, what in events],
                     texts=self.texts)

    def delay_line(self) -> list[dict[str, np.ndarray]]:
        """The delay line's slots per instance and type (a snapshot saves them)."""
        return self.history

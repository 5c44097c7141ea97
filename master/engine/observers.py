"""Observers: read-only views of an execution (metrics, progress). The MCAP logger is in log/logger.py.

An observer sees the execution start, every instance's outputs after each of its steps (with the
time they hold), the end of every tick, the start and end of every fault, and the finish. The tick
loop runs in C and records many ticks per call; an observer takes them as one Batch (on_batch), in
the order they happened. An observer that only implements the per-step methods (on_step, on_tick,
on_fault) gets the same sequence replayed step by step, each instance's values set as they were.
"""

from __future__ import annotations

import sys
import time
import weakref
from dataclasses import dataclass, field

import numpy as np


@dataclass
class Batch:
    """The steps of one call of the tick loop, in order. Arrays are views valid until the next call: copy to keep.

    Record p: instance[p] (an index into names) stepped at tick[p]; its outputs then held the values at time[p]
    and are row[p] of rows[name][type]. events: fault starts and ends, (p, t, fault, "start" | "end"): before
    record p, as they happened."""

    first_tick: int  # the first tick of the call
    ticks: int  # ticks run
    names: list[str]
    instance: np.ndarray
    tick: np.ndarray
    time: np.ndarray
    row: np.ndarray
    rows: dict[str, dict[str, np.ndarray]]
    events: list = field(default_factory=list)
    closing: bool = False  # the run's closing samples at its end (edges.py): steps at tick first_tick, none of them a tick
    texts: dict = field(default_factory=dict)  # name -> {row: {output: its String or Binary value}} (read in Python)

    def positions(self, name: str) -> np.ndarray:
        """The records of one instance, in order."""
        return np.flatnonzero(self.instance == self.names.index(name))

    def head(self, cut: int) -> Batch:
        """The batch's first cut records (and the fault events before them)."""
        rows = {}
        for i, name in enumerate(self.names):
            n = int(np.count_nonzero(self.instance[:cut] == i))
            rows[name] = {typ: r[:n] for typ, r in self.rows[name].items()}
        ticks = int(self.tick[cut - 1]) - self.first_tick + 1 if cut else 0
        return Batch(self.first_tick, ticks, self.names, self.instance[:cut], self.tick[:cut], self.time[:cut], self.row[:cut],
                     rows, [e for e in self.events if e[0] < cut], self.closing, self.texts)

    def latest_before(self, name: str, positions: np.ndarray) -> np.ndarray:
        """For each record position, the row of the named instance's last record before it (-1: none in this batch)."""
        mine = self.instance == self.names.index(name)
        count = np.cumsum(mine) - mine  # its records strictly before each position
        return count[positions] - 1


class Observer:
    threaded = False  # it hands each batch to a thread of its own (the MCAP logger): it is given the batch last

    def start(self, execution) -> None: ...

    def on_batch(self, execution, batch: Batch) -> None:
        """Every step of a call of the tick loop. The default replays them through the per-step methods."""
        replay(execution, batch, [self])

    def on_step(self, instance, t: float) -> None: ...

    def on_tick(self, k: int, t: float) -> None: ...

    def on_fault(self, t: float, fault, what: str) -> None: ...  # what: "start" or "end" (faults/apply.py)

    def finish(self, execution, error: str | None) -> None: ...

    def snapshot_state(self) -> dict | None:
        """What a run continued from a snapshot needs of this observer to go on as if uninterrupted (JSON-able; floats
        round-trip exactly). None: nothing."""
        return None

    def restore_state(self, state: dict) -> None: ...


class StopRun(Exception):
    """An observer ends the run on purpose (a requirement's FAIL is decided, say): raised from on_batch, it stops the
    run once every observer has had the batch (the log holds what the observer saw). The message says why."""


class ReplayStopped(Exception):
    """An observer raised while a batch was replayed: `cut` records had been delivered (the error is the cause)."""

    def __init__(self, cut: int) -> None:
        super().__init__(cut)
        self.cut = cut


def replay(execution, batch: Batch, observers, held: dict | None = None) -> dict | None:
    """The batch step by step for observers of the per-step kind: each instance's values as they were after each of
    its steps (before its first step in the batch: held[name], the values it had when the batch began; without held,
    its values at the batch's end), on_tick at the end of every tick, fault events in their places. The live values
    are restored after, and returned ({name: {type: a copy}}: what the next batch's replay holds; None: no observer).
    An observer's exception stops the replay where it happened: ReplayStopped(cut) from it, cut being the records
    the run got to (the step being delivered included, as the log has it)."""
    if not observers:
        return None
    try:
        return _replay(execution, batch, observers, held)
    except _Stopped as stop:
        raise ReplayStopped(stop.cut) from stop.__cause__


class _Stopped(Exception):
    def __init__(self, cut: int) -> None:
        self.cut = cut


def _replay(execution, batch: Batch, observers, held: dict | None) -> dict:
    slaves = [execution.instances[n] for n in batch.names]
    live = [{t: v.copy() for t, v in s.values.items()} for s in slaves]
    for name, slave in zip(batch.names, slaves) if held is not None else ():
        for typ, values in slave.values.items():
            values[:] = held[name][typ]
    events = iter(batch.events)
    pending = [next(events, None)]  # the next fault event
    tick_of, tick, t0 = batch.tick, execution.system.tick, execution.system.start_time  # t0 + k * tick: tl_loop.c's

    def deliver(p: int) -> None:
        """Record p to the observers, the fault events before it first."""
        while pending[0] is not None and pending[0][0] <= p:
            for obs in observers:
                obs.on_fault(*pending[0][1:])
            pending[0] = next(events, None)
        i = int(batch.instance[p])
        slave, rows = slaves[i], batch.rows[batch.names[i]]
        for typ, values in slave.values.items():
            values[:] = rows[typ][batch.row[p]]
        try:
            for obs in observers:
                obs.on_step(slave, float(batch.time[p]))
        except BaseException as err:
            raise _Stopped(p + 1) from err

    p, n = 0, len(batch.instance)
    try:
        for k in range(batch.first_tick, batch.first_tick + batch.ticks):
            execution.ticks_done, execution.time = k, t0 + k * tick  # where the observers see the run: an exception stops it here
            while p < n and tick_of[p] == k:
                deliver(p)
                p += 1
            execution.ticks_done, execution.time = k + 1, t0 + (k + 1) * tick
            try:
                for obs in observers:
                    obs.on_tick(k + 1, t0 + (k + 1) * tick)
            except BaseException as err:
                raise _Stopped(p) from err
        while batch.closing and p < n:  # a closing batch's samples (edges.py): steps at the run's end, after its last tick
            deliver(p)
            p += 1
        while pending[0] is not None:  # faults that started in a call that then failed
            for obs in observers:
                obs.on_fault(*pending[0][1:])
            pending[0] = next(events, None)
    finally:
        for slave, values in zip(slaves, live):
            for typ, v in values.items():
                slave.values[typ][:] = v
    return dict(zip(batch.names, live))


_REAL_OUTPUTS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # slave -> real_outputs(slave), built once


def real_outputs(instance) -> dict[str, int]:
    """{name: index in values["Real"]} of an instance's Real outputs: looked up by every run's observers as they
    start, built once per instance (a campaign restarts one set of instances for many runs)."""
    names = _REAL_OUTPUTS.get(instance)
    if names is None:
        names = _REAL_OUTPUTS[instance] = {v.name: i for i, v in reversed(list(enumerate(instance.outputs["Real"])))}
    return names


class Progress(Observer):
    """How far a run is and how long it has left, on stderr. On a terminal, one bar redrawn in place (\\r) at most
    twice a second; otherwise (a file, a pipe, CI's log) a plain line every `every` s of wall time, so that a log
    holds readable lines and no carriage-return frames."""

    def __init__(self, stop: float, stream=None, every: float = 10.0, started: float | None = None) -> None:
        self.stop, self.stream = stop, sys.stderr if stream is None else stream
        isatty = getattr(self.stream, "isatty", None)
        self.terminal = bool(isatty and isatty())
        self.interval = 0.5 if self.terminal else every
        # the run's clock (time.perf_counter() when it began, loading included): the one its summary's wall time reads,
        # so the bar's rate and the summary's agree (a clock started after loading said 180x where the run did 35x)
        self._t0 = time.perf_counter() if started is None else started
        self._last = self._t0  # first refresh after 0.5 s, when the rate means something
        self._t_first = 0.0  # the simulated time at the start (a resumed run starts past 0)
        self._origin = 0.0  # the system's start time: the bar's 0 %
        self._drawn = False

    def start(self, execution) -> None:
        self._last = time.perf_counter()
        self._t_first = execution.resumed_at or execution.system.start_time
        self._origin = execution.system.start_time

    def on_batch(self, execution, batch: Batch) -> None:
        k = batch.first_tick + batch.ticks
        self.on_tick(k, execution.system.start_time + k * execution.system.tick)

    def on_tick(self, k, t) -> None:
        now = time.perf_counter()
        if now - self._last < self.interval and (t < self.stop or not self.terminal):
            return
        self._last = now
        self.stream.write(self.frame(t, now - self._t0) if self.terminal else self.line(t, now - self._t0) + "\n")
        self._drawn = True
        self.stream.flush()

    def remaining(self, t: float, elapsed: float) -> float | None:
        """Wall-clock seconds left at the rate so far (None before any simulated time has passed)."""
        done = t - self._t_first
        if done <= 0 or elapsed <= 0:
            return None
        return max(self.stop - t, 0.0) * elapsed / done

    def line(self, t: float, elapsed: float) -> str:
        frac = min((t - self._origin) / (self.stop - self._origin), 1.0) if self.stop > self._origin else 1.0
        left = self.remaining(t, elapsed)
        return (f"  {100 * frac:5.1f} %  t = {t:6.2f} of {self.stop:g} s  ({speed(t - self._t_first, elapsed)}, "
                f"{'?' if left is None else _duration(left)} left)")

    def frame(self, t: float, elapsed: float) -> str:
        frac = min((t - self._origin) / (self.stop - self._origin), 1.0) if self.stop > self._origin else 1.0
        bar = "#" * int(30 * frac)
        return f"\r  [{bar:<30}]" + self.line(t, elapsed) + "   "  # trailing blanks: a shorter frame erases a longer one

    def done(self, t: float, wall: float) -> None:
        """The last frame, at the run's end: t and wall are the run's result's (its summary's figures). On a terminal
        it ends the bar; a redirected stream has its lines already and gets no other."""
        if self.terminal:
            self.stream.write(self.frame(t, wall) + "\n")
            self.stream.flush()


def speed(simulated: float, wall: float) -> str:
    """How fast a run went, as the bar and the run's summary both say it: "35x real time" (two digits below 1x)."""
    rate = simulated / max(wall, 1e-9)
    return f"{rate:.0f}x real time" if rate >= 1 else f"{rate:.2g}x real time"


def seconds(wall: float) -> str:
    """A wall time as the summary says it: 0.042 s for a run too short for tenths, else 3.4 s."""
    return f"{wall:.2g} s" if wall < 1 else f"{wall:.1f} s"


def _duration(seconds: float) -> str:
    """A time left as a person says it: 8 s, 2 min 05 s, 1 h 03 min."""
    s = round(seconds)
    if s < 60:
        return f"{s} s"
    if s < 3600:
        return f"{s // 60} min {s % 60:02d} s"
    return f"{s // 3600} h {s % 3600 // 60:02d} min"

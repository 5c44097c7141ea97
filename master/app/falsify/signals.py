"""The signals a requirement names (`instance.variable`), as an STL trace on the master's tick: from a running loop (an
observer that keeps only those columns) or from a run's MCAP log; the two give the same trace bit for bit.

Sampling: the trace's sample k is at t_k = k T (T the tick). A signal's value there is its instance's last output at or
before t_k (zero-order hold), the output at the start included; an instance the loop steps every tick gives its own
step's output. The trace runs to the last tick any of the signals' instances reached (the plant's step ends one tick
after the others' last output: those hold).

Early stop (`stop_on`): at every CHECK_TICKS-th tick of the run (absolute ticks: a run branched from a snapshot checks
where the whole run does, so both stop at the same tick), the recorder evaluates the formulas on the trace so far, cut
at the last tick every signal has reached (an exact prefix of the whole run's trace: no held value stands in for one
not yet computed). A formula whose robustness's upper bound over every continuation is below 0 has a FAIL that can no
longer change: the recorder raises the requirements' RequirementViolated (master/engine/requirement/observer.py) and
the run stops there.
"""

from __future__ import annotations

import numpy as np

from ...engine.observers import Observer
from ...engine.requirement.observer import RequirementViolated
from ...engine.requirement.stl import Evaluator, Trace, decided_fail, reads_from

TYPES = ("Real", "Integer", "Boolean")
CHECK_TICKS = 256  # ticks between two early-stop checks: the tick loop's own calls (engine/native/loop.py's CHUNK, 3.07 s
# of a 12 ms tick), so a run is not cut into more calls; a check costs ~0.15 ms, which every passing run pays (most of a
# search): two checks in an 8.1 s run, measured against finer ones in docs/falsification.md


def _column(instance, variable: str) -> tuple[str, int]:
    for typ in TYPES:
        for i, v in enumerate(instance.outputs.get(typ, [])):
            if v.name == variable:
                return typ, i
    from ...engine.errors import DescriptionError

    raise DescriptionError(f"signal {instance.name}.{variable}: {instance.name} has no output {variable}")


def sampled(series: dict[str, tuple[np.ndarray, np.ndarray]], tick: float, common: bool = False) -> Trace:
    """A uniform trace on the tick from each signal's (times, values) records (in time order); common: only to the last
    tick every signal has reached (a prefix of what the run goes on to give)."""
    ticks = {name: np.rint(np.asarray(t, dtype=float) / tick).astype(np.int64) for name, (t, _) in series.items()}
    last = (min if common else max)(int(k[-1]) for k in ticks.values())
    first = min(int(k[0]) for k in ticks.values())
    grid = np.arange(first, last + 1)
    signals = {}
    for name, (_, values) in series.items():
        at = np.searchsorted(ticks[name], grid, side="right") - 1
        signals[name] = np.asarray(values, dtype=float)[np.maximum(at, 0)]
    return Trace(grid * tick, signals, tick)


class SignalRecorder(Observer):
    """Keeps the named outputs of every step (and their values at the start), nothing else; `trace()` after the run.
    stop_on: parsed formulas whose decided FAIL stops the run (module docstring); `stopped_at` is then the time of the
    last tick of the trace that decided it."""

    def __init__(self, names: list[str], stop_on: list | None = None) -> None:
        self.names = list(names)
        self.stop_on = list(stop_on or [])
        self.stopped_at: float | None = None
        self._times: dict[str, list[np.ndarray]] = {}
        self._values: dict[str, list[np.ndarray]] = {}

    def start(self, execution) -> None:
        self.tick = execution.system.tick
        self._where = {}
        by_instance: dict[str, list[str]] = {}
        for name in self.names:
            instance, _, variable = name.partition(".")
            if instance not in execution.instances:
                from ...engine.errors import DescriptionError

                raise DescriptionError(f"signal {name}: the loop has no instance {instance}")
            self._where[name] = (instance, *_column(execution.instances[instance], variable))
            by_instance.setdefault(instance, []).append(name)
        self._instances = by_instance
        t0 = float(execution.time)
        for name, (instance, typ, i) in self._where.items():
            self._times[name] = [np.array([t0])]
            self._values[name] = [np.array([execution.instances[instance].values[typ][i]], dtype=float)]

    def on_batch(self, execution, batch) -> None:
        for instance, names in self._instances.items():
            at = batch.positions(instance)
            if not len(at):
                continue
            times, rows = batch.time[at].copy(), batch.row[at]
            for name in names:
                _, typ, i = self._where[name]
                self._times[name].append(times)
                self._values[name].append(batch.rows[instance][typ][rows, i].astype(float))
        if self.stop_on and execution.ticks_done % CHECK_TICKS == 0:
            self._check()

    def common_length(self) -> int:
        """len(self.trace(common=True)), from each signal's first and last record alone (rounded as sampled() rounds)."""
        ticks = [(round(float(self._times[n][0][0]) / self.tick), round(float(self._times[n][-1][-1]) / self.tick))
                 for n in self.names]
        return max(0, min(last for _, last in ticks) - min(first for first, _ in ticks) + 1)

    def _check(self) -> None:
        length = self.common_length()
        if all(reads_from(f, self.tick) >= length for f in self.stop_on):
            return  # every sample any formula reads is still to come (decided_fail's own test, before the trace is made)
        trace = self.trace(common=True)
        ev = Evaluator(trace, False)
        for formula in self.stop_on:
            if decided_fail(formula, trace, ev):
                self.stopped_at = float(trace.times[-1])
                raise RequirementViolated(f"a requirement's FAIL is decided at t = {self.stopped_at:.3f} s")

    def snapshot_state(self) -> dict:
        """The records so far: a run branched from a snapshot of this one gets them (its trace is the whole run's)."""
        return {"times": {n: np.concatenate(self._times[n]).tolist() for n in self.names},
                "values": {n: np.concatenate(self._values[n]).tolist() for n in self.names}}

    def restore_state(self, state: dict) -> None:
        self._times = {n: [np.array(state["times"][n], dtype=float)] for n in self.names}
        self._values = {n: [np.array(state["values"][n], dtype=float)] for n in self.names}

    @property
    def started(self) -> bool:
        """The run reached its start (the instances initialized): there is a trace to judge."""
        return bool(self._times)

    def series(self) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        return {n: (np.concatenate(self._times[n]), np.concatenate(self._values[n])) for n in self.names}

    def trace(self, common: bool = False) -> Trace:
        return sampled(self.series(), self.tick, common)


def trace_from_log(path, names: list[str], tick: float) -> Trace:
    """The same trace from a run's MCAP log (its /instance topics; master/engine/log/reader.py)."""
    from ...engine.log import reader as log_reader

    topics = sorted({"/" + n.partition(".")[0] for n in names})
    data = log_reader.read(path, topics)
    series = {}
    for name in names:
        instance, _, variable = name.partition(".")
        records = data.get("/" + instance, [])
        if not records or variable not in records[0]:
            from ...engine.errors import DescriptionError

            raise DescriptionError(f"{path}: the log has no signal {name}")
        series[name] = (np.array([r["t"] for r in records]), np.array([float(r[variable]) for r in records]))
    return sampled(series, tick)

"""Requirements monitored while a run goes (docs/requirements.md, "Online").

The observer keeps, batch by batch, the columns of the outputs the requirements read (a few numpy copies a call of the
tick loop, no Python per tick), as the log holds them: the values at t = 0, then after each step. At the end it
builds the trace with the function the offline check uses (requirement_check.build_trace), so the verdicts online and
offline agree bit for bit; the log gets a /requirements channel (each requirement's robustness at every tick: the
robustness of its formula evaluated from that tick on; fixed-layout protobuf, one double a requirement, the names in
the channel's metadata) and a "requirements" metadata record (the verdicts).

stop_on_violation: after each batch (at most every CHECK_EVERY ticks), the robustness's upper bound over every way the
run could go on (stl.robustness "upper"); once it is below 0 for a requirement, its FAIL cannot change and the run
stops (StopRun) after every observer has had the batch.
"""

from __future__ import annotations

import json
import re

import numpy as np

from .. import edges
from ..observers import Observer, StopRun
from .check import STOPPED_ON_VIOLATION, Result, build_trace, check_trace, ended_by_error, split
from .files import Requirement, check_signals
from .stl import Evaluator, decided_fail, verdict

CHECK_EVERY = 64  # ticks between two early-stop checks (a run stepped tick by tick would otherwise re-evaluate every tick)


class RequirementViolated(StopRun):
    """A requirement's FAIL is decided: the run stops (--stop-on-violation)."""


class RequirementObserver(Observer):
    def __init__(self, requirements: list[Requirement], stop_on_violation: bool = False, log_every: int = 1) -> None:
        """log_every: see every n-th step of each instance, as the log does with log_every (so the two agree)."""
        self.requirements = list(requirements)
        self.stop_on_violation = stop_on_violation
        self.log_every = log_every
        self.results: list[Result] = []
        self.stopped_by: str | None = None
        self._names = sorted({n for r in self.requirements for n in r.signals})
        self._since_check = 0

    def start(self, execution) -> None:
        available = {f"{name}.{v.name}": "number" for name, inst in execution.instances.items()
                     for vs in inst.outputs.values() for v in vs}
        check_signals(self.requirements, available, "this run's outputs")
        self._columns: dict[str, dict[str, tuple[str, int]]] = {}  # instance -> variable -> (type, index)
        for name in self._names:
            instance, variable = split(name)
            inst = execution.instances[instance]
            for typ, vs in inst.outputs.items():
                for i, v in enumerate(vs):
                    if v.name == variable:
                        self._columns.setdefault(instance, {})[variable] = (typ, i)
        self._times: dict[str, list[np.ndarray]] = {i: [] for i in self._columns}
        self._values: dict[str, dict[str, list[np.ndarray]]] = {i: {v: [] for v in cols} for i, cols in self._columns.items()}
        timing = {i.name: i.timing for i in execution.system.instances}
        # the logger's count of each instance's messages (edges.py): one at t = 0 after initialization if its kind has it
        self._steps = {i: edges.messages_before(timing[i], execution.ticks_done, execution.every[i]) for i in self._columns}
        if getattr(execution, "resumed_at", None) is None:  # the values at t = 0, as the log has them
            for instance, cols in self._columns.items():
                inst = execution.instances[instance]
                if not edges.logs_initial(timing[instance]):
                    continue
                self._times[instance].append(np.zeros(1))
                for variable, (typ, i) in cols.items():
                    self._values[instance][variable].append(np.array([inst.values[typ][i]], dtype=float))
        # instance -> type -> (the columns read, the batches' blocks of them)
        self._blocks = {instance: {typ: (np.array([i for t, i in cols.values() if t == typ]), []) for typ in {t for t, _ in cols.values()}}
                        for instance, cols in self._columns.items()}
        for logger in execution.observers:
            if hasattr(logger, "closing"):  # the MCAP logger: the channel and the verdicts go in before it closes
                logger.closing.append(self._to_log)

    def on_batch(self, execution, batch) -> None:
        for instance in self._columns:
            mine = batch.positions(instance)
            if not len(mine):
                continue
            if self.log_every > 1:
                k = self._steps[instance] + np.arange(len(mine))
                self._steps[instance] += len(mine)
                mine = mine[k % self.log_every == 0]
            self._times[instance].append(batch.time[mine])  # fancy indexing: a copy
            rows = batch.row[mine]
            for typ, (indices, blocks) in self._blocks[instance].items():  # one copy a type, the columns split at the end
                blocks.append(batch.rows[instance][typ].take(rows, axis=0).take(indices, axis=1))  # take: 2x np.ix_'s speed
        self._since_check += batch.ticks
        if self.stop_on_violation and self._since_check >= CHECK_EVERY:
            self._since_check = 0
            self._check_early()

    def _series(self) -> dict:
        for instance, cols in self._columns.items():  # the blocks taken since, into the columns
            for typ, (indices, blocks) in self._blocks[instance].items():
                if blocks:
                    block = np.concatenate(blocks).astype(float, copy=False)
                    blocks.clear()
                    for variable, (t, i) in cols.items():
                        if t == typ:
                            self._values[instance][variable].append(block[:, int(np.flatnonzero(indices == i)[0])])
        return {i: (np.concatenate(self._times[i]) if self._times[i] else np.zeros(0),
                    {v: np.concatenate(chunks) if chunks else np.zeros(0) for v, chunks in self._values[i].items()})
                for i in self._columns}

    def _check_early(self) -> None:
        series = self._series()
        for req in self.requirements:
            trace = build_trace(series, req.signals)
            ev = Evaluator(trace, final=False)
            if decided_fail(req.formula, trace, ev):  # the upper bound alone; the verdict for its violation's time
                v = verdict(req.formula, trace, final=False, evaluator=ev)
                self.stopped_by = req.name
                raise RequirementViolated(f"requirement '{req.name}' violated at t = {v.violation_time:.3f} s, its FAIL can no "
                                          f"longer change: {STOPPED_ON_VIOLATION}")

    def finish(self, execution, error) -> None:
        if not self.results:  # no log (its closing hook evaluates them otherwise)
            self._evaluate(error)

    def _evaluate(self, error: str | None) -> None:
        """The verdicts (ERROR each for a run that failed or diverged: check.ended_by_error), and each requirement's
        robustness at every tick of its trace (one evaluation serves both)."""
        final = error is None
        series = self._series()
        if not any(len(t) for t, _ in series.values()):
            return
        self._rho = {}
        cache: dict = {}
        traces = {r.name: build_trace(series, r.signals, cache) for r in self.requirements}
        evaluators = {r.name: Evaluator(traces[r.name], final) for r in self.requirements}
        self.results = ended_by_error(check_trace(self.requirements, lambda r: traces[r.name], final=final,
                                                  evaluator_for=lambda r: evaluators[r.name]), error)
        for r in self.requirements:
            self._rho[r.name] = (traces[r.name], evaluators[r.name](r.formula))

    def _to_log(self, logger, error) -> None:
        """Before the log closes: the verdicts as metadata, each requirement's robustness over time as a channel (one
        double a requirement, at every tick; NaN where its trace has no sample)."""
        self._evaluate(error)
        if not self.results:
            return
        logger.final_metadata["requirements"] = {r.name: _summary(r) for r in self.results}
        logger.final_metadata["requirement_formulas"] = {r.name: r.text for r in self.requirements}  # the figures redraw them
        longest = max((trace for trace, _ in self._rho.values()), key=len)
        keys = np.rint(longest.times / longest.period).astype(np.int64)
        table = np.full((len(keys), len(self._rho)), np.nan)
        for j, (trace, rho) in enumerate(self._rho.values()):
            at = np.searchsorted(keys, np.rint(trace.times / longest.period).astype(np.int64))
            table[at, j] = rho
        columns = _identifiers(list(self._rho))
        logger.add_rows_channel("/requirements", "requirements", columns, longest.times, table,
                                {"requirements": json.dumps(dict(zip(columns, self._rho)))})


def _identifiers(names: list[str]) -> list[str]:
    """Field names for the channel: a requirement's name with what is not a letter, digit or _ as _, unique."""
    out: list[str] = []
    for name in names:
        field = re.sub(r"\W", "_", name)
        field = field if re.match(r"[A-Za-z_]", field) else f"r_{field}"
        while field in out or field == "t":
            field += "_"
        out.append(field)
    return out


def _summary(r: Result) -> str:
    """One metadata value: the verdict, the robustness, the first violation."""
    text = r.shown + ("" if r.robustness is None else f" {r.robustness!r}")  # "PASS (vacuous) 0.5" for a vacuous pass
    if r.first_violation is not None:
        text += f" at {r.first_violation!r}"
    return text

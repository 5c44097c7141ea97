"""Requirements checked on a run: its signals sampled on the master's tick, each requirement's verdict at the start.

The trace: every instance's messages (the values after each of its steps, and at t = 0), held from one message to the
next, read at each time any of the instances the requirements read has a message (the tick). The same function builds
it from a log (offline: check_log) and from the steps a run hands its observers (online: requirement/observer.py), so
the two agree bit for bit.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np

from .files import Requirement, RequirementError, check_signals, load
from .stl import Evaluator, StlError, Trace, verdict


@dataclass(frozen=True)
class Result:
    """One requirement's verdict on one run."""

    name: str
    verdict: str  # PASS, FAIL, INCONCLUSIVE, ZERO (robustness exactly 0), ERROR (the run failed or diverged: ended_by_error)
    robustness: float | None  # None: not decided (INCONCLUSIVE, or a FAIL decided before the horizon: see bounds)
    first_violation: float | None  # s, FAIL only
    values: dict[str, float] = field(default_factory=dict)  # the requirement's signals at the first violation
    bounds: tuple[float, float] = (-math.inf, math.inf)  # what the robustness can still be
    why: str = ""  # for INCONCLUSIVE: what is missing
    formula: str = ""
    description: str = ""
    source: str = ""
    vacuous: bool = False  # a PASS (or ZERO) of `always[a:b] (p implies q)` whose p never held: nothing was tested

    @property
    def shown(self) -> str:
        """The verdict as tables and stored verdict columns show it: "PASS (vacuous)" for a vacuous pass."""
        return f"{self.verdict} (vacuous)" if self.vacuous else self.verdict

    def to_json(self) -> dict:
        """Valid JSON (RFC 8259 has no NaN or Infinity): a number that is not finite is the text "inf", "-inf", "nan"."""
        d = asdict(self)
        d["bounds"] = [json_number(b) for b in self.bounds]
        d["robustness"] = None if self.robustness is None else json_number(self.robustness)
        d["values"] = {k: json_number(v) for k, v in self.values.items()}
        return d


ERROR = "ERROR"
STOPPED_ON_VIOLATION = "run stopped (--stop-on-violation)"  # in the error line of a run a requirement's FAIL stopped


def ended_by_error(results: list[Result], error: str | None) -> list[Result]:
    """The results of a run that ended with `error` (the log's error line): a run that failed or diverged judged nothing,
    each requirement ERROR with the error's line (its time in it), never the FAIL of the values the failure cut or
    blew up (a campaign's rows say the same); a run a requirement's FAIL stopped keeps its verdicts."""
    if not error or STOPPED_ON_VIOLATION in error:
        return results
    why = f"the run ended in an error, nothing judged: {error}"
    return [replace(r, verdict=ERROR, robustness=None, first_violation=None, values={}, bounds=(-math.inf, math.inf),
                    why=why, vacuous=False) for r in results]


def json_number(x: float):
    """x, or for a value JSON cannot hold, its name: "inf", "-inf", "nan"."""
    return x if math.isfinite(x) else "nan" if math.isnan(x) else ("inf" if x > 0 else "-inf")


def split(name: str) -> tuple[str, str]:
    """instance.variable -> (instance, variable): the instance is the part before the first dot."""
    instance, _, variable = name.partition(".")
    return instance, variable


def build_trace(series: dict[str, tuple[np.ndarray, dict[str, np.ndarray]]], names: list[str], cache: dict | None = None) -> Trace:
    """The trace of the named signals on the tick. series: instance -> (message times in log order, its variables'
    values). The tick is the shortest time between two messages of an instance; each message belongs to the tick
    nearest its time (instances compute their times each their own way: 3 * 0.012 and 0.036 differ in the last bit);
    a signal holds its last message's value (the latest of those at one tick) until its next; the trace ends at the
    last tick every instance has reached, or at the run's end off the tick after a shorter last step. cache: a dict
    kept across calls on the same series (held signals)."""
    used = sorted({split(n)[0] for n in names})
    if not used:
        raise StlError("no signal")
    cache = {} if cache is None else cache
    span_key = ("span", *used)
    if span_key not in cache:  # the tick and the span: once per set of instances
        every = np.concatenate([series[i][0] for i in used])
        # an instance's last gap may be a shorter last step (docs/master.md, "Signals at a run's edges"): not the tick
        gaps = np.concatenate([np.diff(_sorted(series[i][0]))[:-1 if len(series[i][0]) > 2 else None] for i in used])
        gaps = gaps[gaps > 1e-9]
        if not len(gaps):
            return Trace.uniform(every[:1], {n: _held(series, n, np.zeros(1, dtype=np.int64), 1.0)[:1] for n in names}, 1.0)
        tick = float(gaps.min())
        # from the first message to the last tick every instance has reached (past its last message an instance's value
        # is not known: the plant's state after the last step has no controller's output of that time)
        end = min(series[i][0].max() for i in used)
        first, last = int(np.rint(every.min() / tick)), int(np.rint(end / tick))
        cache[span_key] = (tick, first, last, np.arange(first, last + 1), end)
    tick, first, last, keys, end = cache[span_key]
    values = {}
    for n in names:
        key = (n, tick, first, last)
        if key not in cache:
            instance, variable = split(n)
            at_key = (instance, tick, first, last)
            if at_key not in cache:  # which message each tick holds: once per instance
                cache[at_key] = _holding(series[instance][0], keys, tick)
            at, order = cache[at_key]
            column = np.asarray(series[instance][1][variable], dtype=float)
            column = column if order is None else column[order]
            cache[key] = np.where(at >= 0, column[np.maximum(at, 0)], np.nan)
        values[n] = cache[key]
    times = keys * tick
    if len(times) > 1 and abs(times[-1] - end) > 1e-6 * tick:  # the run ended off the tick (a shorter last step)
        times[-1] = end
    return Trace.uniform(times, values, tick)


def _sorted(x: np.ndarray) -> np.ndarray:
    return x if len(x) < 2 or bool(np.all(x[1:] >= x[:-1])) else np.sort(x)


def _holding(times: np.ndarray, keys: np.ndarray, tick: float) -> tuple[np.ndarray, np.ndarray | None]:
    """(the message each tick holds, -1 for none yet; the order that sorts the messages by tick, None if they are)."""
    own = np.rint(times / tick).astype(np.int64)
    order = None
    if len(own) > 1 and not bool(np.all(own[1:] >= own[:-1])):
        order = np.argsort(own, kind="stable")  # the last message at a tick is the latest
        own = own[order]
    return np.searchsorted(own, keys, side="right") - 1, order


def _held(series, name: str, keys: np.ndarray, tick: float) -> np.ndarray:
    instance, variable = split(name)
    at, order = _holding(series[instance][0], keys, tick)
    column = np.asarray(series[instance][1][variable], dtype=float)
    column = column if order is None else column[order]
    return np.where(at >= 0, column[np.maximum(at, 0)], np.nan)


def check_trace(reqs: list[Requirement], trace_for, final: bool = True, evaluator_for=None) -> list[Result]:
    """Each requirement's verdict; trace_for(requirement) -> Trace, or why it is missing (text: INCONCLUSIVE).
    evaluator_for(requirement) -> its trace's Evaluator, for a caller that wants more of it afterwards."""
    out = []
    for req in reqs:
        trace = trace_for(req)
        if isinstance(trace, str):
            out.append(Result(req.name, "INCONCLUSIVE", None, None, why=trace, formula=req.text, description=req.description,
                              source=req.source))
            continue
        try:
            v = verdict(req.formula, trace, final, evaluator_for(req) if evaluator_for else Evaluator(trace, final))
        except StlError as err:
            raise RequirementError(f"requirement '{req.name}': {err}") from None
        why = ""
        span = trace.times[-1] - trace.times[0]
        if v.unknown:
            why = _not_a_number(req, trace)
        elif v.verdict == "INCONCLUSIVE":
            why = (f"the run covers {span:g} s of the {req.horizon:g} s the requirement looks at" if span < req.horizon
                   else f"the run ended early, at {trace.times[-1]:g} s: what holds to the end of the run is open")
        out.append(Result(req.name, v.verdict, v.robustness, v.violation_time, v.violation_values, v.bounds, why, req.text,
                          req.description, req.source, v.vacuous))
    return out


def _not_a_number(req: Requirement, trace: Trace) -> str:
    """Why a verdict was judged over values not known: the first NaN sample of the requirement's signals."""
    firsts = [(float(trace.times[int(np.argmax(np.isnan(trace.signals[n])))]), n) for n in req.signals
              if n in trace.signals and np.isnan(trace.signals[n]).any()]
    if firsts:
        t, name = min(firsts)
        return f"{name} is NaN from t = {t:g} s: judged for any value it could have had"
    return "the formula computes NaN (0 / 0, inf - inf): judged for any value it could have had"


def log_series(messages: dict[str, list[dict]]) -> tuple[dict, dict[str, str]]:
    """(instance -> (times, {variable: values}), every signal -> "number" or what it is instead) of a log's messages."""
    series, kinds = {}, {}
    for topic, msgs in messages.items():
        if not msgs or not isinstance(msgs[0], dict) or "t" not in msgs[0]:
            continue
        instance = topic.lstrip("/")
        times = np.array([m["t"] for m in msgs], dtype=float)
        columns = {}
        for key, first in msgs[0].items():
            if key == "t":
                continue
            name = f"{instance}.{key}"
            if first is None or isinstance(first, (bool, int, float)):
                kinds[name] = "number"
                columns[key] = np.array([np.nan if m.get(key) is None else float(m[key]) for m in msgs])
            else:
                kinds[name] = f"a {type(first).__name__}"
        series[instance] = (times, columns)
    return series, kinds


def as_requirements(requirements) -> list[Requirement]:
    if isinstance(requirements, (str, Path)):
        return load(Path(requirements))
    reqs = list(requirements)
    if not all(isinstance(r, Requirement) for r in reqs):
        raise RequirementError("requirements: a requirement file's path or a list of Requirement")
    return reqs


def run_stop_time(metadata: dict[str, dict]) -> float | None:
    """The stop time the run was started with (its "run" record), if the log says."""
    try:
        return float(metadata["run"]["stop_time"])
    except (KeyError, TypeError, ValueError):
        return None


def check_log(log_path, requirements, missing: str = "error") -> list[Result]:
    """Each requirement's verdict on one MCAP log (requirements: a requirement file's path, or Requirement objects).

    A log cut short (a killed run, no footer) is a trace that could have gone on; a damaged one raises DamagedLog. A
    signal the log does not have raises RequirementError naming the closest names (missing="inconclusive": that
    requirement is INCONCLUSIVE instead, for a log of a loop without it)."""
    from ..log import reader as log_reader

    reqs = as_requirements(requirements)
    from ..user_files import UserFileError, regular_file

    path = Path(log_path)
    try:
        regular_file(path, "log")
    except UserFileError as err:
        raise RequirementError(str(err)) from None
    topics = sorted({f"/{split(n)[0]}" for r in reqs for n in r.signals})
    columns, state = log_reader.read_columns(path, topics)
    if state.damage is not None:
        raise log_reader.DamagedLog(state.describe(path))
    # a run killed (no footer) or ended by an error (--stop-on-violation too) could have gone on: not the whole run
    error = log_reader.read_metadata(path).get("error")
    final = not state.torn and error is None
    error = str(error.get("message", "")) if isinstance(error, dict) else None
    series = {topic.lstrip("/"): (times, values) for topic, (times, values) in columns.items()}
    kinds = {f"{instance}.{field}": "number" for instance, (_, values) in series.items() for field in values}
    absent = [n for r in reqs for n in r.signals if n not in kinds]
    if absent and missing == "inconclusive":
        def trace_for(r: Requirement):
            gone = [n for n in r.signals if kinds.get(n) != "number"]
            return f"{path.name} has no signal {gone[0]}" if gone else _trace(series, r)
        return ended_by_error(check_trace(reqs, trace_for, final=final), error)
    if absent:  # read every channel to name what there is (and what is there but not a number)
        kinds = log_series(log_reader.read_checked(path)[0])[1]
    check_signals(reqs, kinds, str(path))
    cache: dict = {}
    return ended_by_error(check_trace(reqs, lambda r: _trace(series, r, cache), final=final), error)


def _trace(series, req: Requirement, cache: dict | None = None) -> Trace:
    try:
        return build_trace(series, req.signals, cache)
    except StlError as err:
        raise RequirementError(f"requirement '{req.name}': {err}") from None


def log_span(log_path) -> float:
    """How long the run was meant to last: its stop time, or the last message's time."""
    from ..log import reader as log_reader

    stop = run_stop_time(log_reader.read_metadata(Path(log_path)))
    if stop is not None:
        return stop
    state = log_reader.check(Path(log_path))
    return state.duration if state.duration is not None else (state.intact_until or 0.0)


def margins(req: Requirement, trace: Trace, final: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """(times, margin) to draw a requirement: for always[a:b] φ (the usual form) the robustness of φ over the window
    from the run's start, whose negative stretches are the violations; else the formula's robustness from each tick."""
    from .stl.syntax import Always

    ev = Evaluator(trace, final)
    if isinstance(req.formula, Always):
        lo, hi = trace.ticks(req.formula.a), min(len(trace) - 1, trace.ticks_end(req.formula.b))
        return trace.times[lo:hi + 1], ev(req.formula.arg)[lo:hi + 1]
    return trace.times, ev(req.formula)


def intervals(times: np.ndarray, bad: np.ndarray) -> list[tuple[float, float]]:
    """The stretches of consecutive samples where bad holds, as (first time, last time)."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], bad.astype(np.int8), [0]])))
    return [(float(times[a]), float(times[b - 1])) for a, b in zip(edges[::2], edges[1::2])]

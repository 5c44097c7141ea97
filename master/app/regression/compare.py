"""`tiltload compare`: a run's metrics against a baseline (another log, or a committed metrics file).

A metric passes if |run - base| <= atol + rtol * |base| (numpy.isclose semantics). Tolerances: an rtol or atol
given on the command line, for every metric; else the baseline file's "tolerances" (per metric, or global); else
DEFAULT_RTOL, DEFAULT_ATOL.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

from ...engine.errors import DescriptionError
from ...engine.log.reader import DamagedLog, check, read_log, read_metadata
from .baseline_schema import FMUS, MAX_KEYS, MAX_NAME, RUN, checked

_TOLERANCE = {"type": "number", "minimum": 0}
_TOLERANCES = {"type": "object", "properties": {"rtol": _TOLERANCE, "atol": _TOLERANCE},
               "additionalProperties": {"type": "object", "additionalProperties": False,
                                        "properties": {"rtol": _TOLERANCE, "atol": _TOLERANCE}}}
BASELINE_SCHEMA = {  # a baseline .json (regression/reproduce.write_baselines writes them; seed, spread are notes)
    "type": "object", "required": ["metrics"],
    "properties": {
        "metrics": {"type": "object", "maxProperties": MAX_KEYS,
                    "propertyNames": {"maxLength": MAX_NAME, "pattern": r"^[^\x00-\x1f\x7f]+$"},
                    "additionalProperties": {"type": "number"}},
        "tolerances": _TOLERANCES, "run": RUN, "fmus": FMUS,
    },
}


def load_case(path: Path) -> dict | None:
    """The case record of a log (its "run" metadata) or of a baseline file (its "run" entry); None if it names none."""
    path = Path(path)
    if path.suffix == ".json":
        from ...engine.user_files import read_json

        data = read_json(path)  # load_metrics has checked it (BASELINE_SCHEMA)
        record = data.get("run") if isinstance(data, dict) else None
        return record if isinstance(record, dict) else None
    return read_metadata(path).get("run")


def load_metrics(path: Path, notes=None) -> tuple[dict[str, float], dict]:
    """(metrics, tolerances) from a .mcap log (its "metrics" record) or a baseline .json.

    A log without a metrics record (a killed run, truncated) gets its metrics recomputed from its
    messages; `notes` (a list) receives a line saying so."""
    from ...engine.user_files import open_binary, regular_file

    path = regular_file(path)
    if path.suffix == ".json":

        from ...engine.user_files import UserFileError, read_json

        try:
            data = read_json(path)
        except UserFileError as err:
            raise DescriptionError(f"{path} is not a metrics file: {str(err).removeprefix(f'{path}: ')}") from None
        checked(data, BASELINE_SCHEMA, str(path), "a metrics file")
        metrics, tolerances = {k: float(v) for k, v in data["metrics"].items()}, data.get("tolerances", {})
        if not metrics:
            raise DescriptionError(f"{path} holds no metrics: nothing to compare")
        if not all(math.isfinite(v) for v in metrics.values()):
            raise DescriptionError(f"{path} holds a non-finite metric")
        _check_tolerances(tolerances, path)
        return metrics, tolerances
    with open_binary(path) as f:
        if f.read(8) != b"\x89MCAP0\r\n":
            raise DescriptionError(f"{path} is not a readable MCAP log (no MCAP magic at its start)")
    state = check(path)
    if state.damage is not None:  # its metrics record may read, but a damaged log is no run to compare
        raise DamagedLog(state.describe(path))
    meta = read_metadata(path)
    if "metrics" not in meta:
        from .log_metrics import metrics_from_messages

        data, truncated = read_log(path, topics=["/plant", "/scenario", "/controller"])
        if not data.get("/controller") or not data.get("/plant"):
            raise DescriptionError(f"{path} has no metrics record and no loop messages (not a tiltload run of the thesis loop?)")
        try:
            end = float(meta["run"]["stop_time"])  # a closing sample is at or after it (engine/edges.py)
        except (KeyError, TypeError, ValueError):
            end = None
        metrics, last = metrics_from_messages(data, end=end)
        if notes is not None:
            notes.append(f"{path} {'is truncated (no footer: a killed run)' if truncated else 'has no metrics record'}: "
                         f"metrics recomputed from its messages up to t = {last:.3f} s")
        return metrics, {}
    record = meta["metrics"]
    if record.get("complete") != "True":
        raise DescriptionError(f"{path} is an incomplete run (stopped after {record.get('ticks')} ticks)")
    return {k: float(v) for k, v in record.items() if k not in ("ticks", "complete")}, {}


def _check_tolerances(tolerances, path: Path) -> None:
    """A baseline's tolerances: {rtol, atol} globally or per metric, each finite and >= 0."""
    if not isinstance(tolerances, dict):
        raise DescriptionError(f"{path}: tolerances must be a mapping")
    for key, value in tolerances.items():
        if isinstance(value, dict):
            _check_tolerances(value, path)
        elif key in ("rtol", "atol"):
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not (math.isfinite(value) and value >= 0):
                raise DescriptionError(f"{path}: tolerance {key} = {value!r} must be a finite number >= 0")


DEFAULT_RTOL, DEFAULT_ATOL = 1e-6, 1e-12


def overridden(tolerances: dict, rtol: float | None, atol: float | None) -> dict:
    """A baseline's tolerances with the given rtol / atol in place of its own, globally and in every metric."""
    given = {k: v for k, v in (("rtol", rtol), ("atol", atol)) if v is not None}
    out = {k: ({**v, **given} if isinstance(v, dict) else v) for k, v in tolerances.items() if k not in given}
    return {**out, **given}


class MetricRow(NamedTuple):
    """One metric of a comparison: passed if abs_diff <= atol + rtol * |baseline|."""

    metric: str
    run: float
    baseline: float
    abs_diff: float
    rel_diff: float
    rtol: float
    atol: float
    status: str  # ok, DIFFERS, MISSING (the run lacks it)


def compare(run: dict[str, float], base: dict[str, float], rtol: float, atol: float, tolerances: dict) -> tuple[bool, list[MetricRow]]:
    rows, ok = [], True
    for name in base:
        tol = tolerances.get(name, tolerances)
        r, a = float(tol.get("rtol", rtol)), float(tol.get("atol", atol))
        if name not in run:
            rows.append(MetricRow(name, math.nan, base[name], math.nan, math.nan, r, a, "MISSING"))
            ok = False
            continue
        diff = abs(run[name] - base[name])
        rel = diff / abs(base[name]) if base[name] else (0.0 if diff == 0 else math.inf)
        passed = diff <= a + r * abs(base[name])
        ok &= passed
        rows.append(MetricRow(name, run[name], base[name], diff, rel, r, a, "ok" if passed else "DIFFERS"))
    return ok, rows


@dataclass(frozen=True)
class Comparison:
    """A run's metrics against a baseline's, after their cases were checked to be the same (or any_case was asked)."""

    ok: bool  # every metric within its tolerance
    rows: list[MetricRow]
    case_differences: list[str] = field(default_factory=list)  # what differs between the cases (compared with any_case)
    notes: list[str] = field(default_factory=list)  # recomputed metrics, a side that names no case
    changes: list[str] = field(default_factory=list)  # what changed in the FMUs and their parameters (changes.py), told first

    def table(self) -> str:
        return format_rows(self.rows)

    def changed_line(self) -> str | None:
        """"what changed: controller parameter x_0 1.7 -> 1.75; plant, scenario and sensors unchanged", or None."""
        from .changes import summary

        return summary(self.changes) if self.changes else None


def different_cases(run_name: str, base_name: str, what: list[str]) -> str:
    """The one line `compare` says when the two runs are different cases."""
    return (f"{run_name} and {base_name} are different cases ({'; '.join(what)}): their metrics are not compared "
            "(--any-case compares them anyway)")


def compare_cases(run_case: dict | None, base_case: dict | None, run_name: str, base_name: str, any_case: bool,
                  notes: list[str]) -> list[str]:
    """What differs between the two cases; a DescriptionError saying it in one line unless any_case."""
    from ..case.record import differences

    if run_case is None or base_case is None:
        which = [n for n, c in ((run_name, run_case), (base_name, base_case)) if c is None]
        notes.append(f"{' and '.join(which)} {'names' if len(which) == 1 else 'name'} no case: the case is not checked")
        return []
    what = differences(run_case, base_case)
    if what and not any_case:
        raise DescriptionError(different_cases(run_name, base_name, what))
    if what:
        notes.append(f"different cases ({'; '.join(what)}), compared as --any-case asks")
    return what


def compare_files(run: Path, baseline: Path, rtol: float | None = None, atol: float | None = None,
                  any_case: bool = False) -> Comparison:
    """`tiltload compare RUN BASELINE`: the cases first, then the metrics."""
    notes: list[str] = []
    run_metrics, _ = load_metrics(run, notes)
    base, tol = load_metrics(baseline, notes)
    run_case, base_case = load_case(run), load_case(baseline)
    what = compare_cases(run_case, base_case, str(run), str(baseline), any_case, notes)
    ok, rows = compare(run_metrics, base, DEFAULT_RTOL, DEFAULT_ATOL, overridden(tol, rtol, atol))
    from .changes import between, load_fmus

    return Comparison(ok, rows, what, notes, between(load_fmus(baseline), load_fmus(run), base_case, run_case))


def format_rows(rows) -> str:
    lines = [f"{'metric':>12} {'run':>14} {'baseline':>14} {'abs diff':>10} {'rel diff':>10} {'rtol':>8}  status"]
    for name, r, b, d, rel, rt, _, status in rows:
        lines.append(f"{name:>12} {r:>14.8g} {b:>14.8g} {d:>10.3g} {rel:>10.3g} {rt:>8.1g}  {status}")
    return "\n".join(lines)


def compare_verdicts(run: list, base: list, rtol: float, atol: float) -> tuple[bool, list[tuple]]:
    """Requirements' results (requirement_check.Result) of a run against a baseline's: a verdict that changes is a
    difference; robustness (when both have one) passes if |run - base| <= atol + rtol * |base|."""
    rows, ok = [], True
    by_name = {r.name: r for r in run}
    for b in base:
        r = by_name.get(b.name)
        if r is None:
            rows.append((b.name, "-", b.verdict, math.nan, math.nan, "MISSING"))
            ok = False
            continue
        status = "ok"
        if r.verdict != b.verdict:
            status = "VERDICT CHANGED"
        elif r.robustness is not None and b.robustness is not None and not (
                abs(r.robustness - b.robustness) <= atol + rtol * abs(b.robustness)):
            status = "DIFFERS"
        ok &= status == "ok"
        rows.append((b.name, r.verdict, b.verdict, _or_nan(r.robustness), _or_nan(b.robustness), status))
    return ok, rows


def _or_nan(x):
    return math.nan if x is None else x


def format_verdict_rows(rows) -> str:
    width = max([11] + [len(r[0]) for r in rows])
    lines = [f"{'requirement':>{width}} {'run':>12} {'baseline':>12} {'robustness':>14} {'baseline':>14}  status"]
    for name, rv, bv, rr, br, status in rows:
        lines.append(f"{name:>{width}} {rv:>12} {bv:>12} {rr:>14.8g} {br:>14.8g}  {status}")
    return "\n".join(lines)

"""tiltload.compare: a run against a baseline, as `tiltload compare` does (the case first, then the metrics)."""

from __future__ import annotations

from pathlib import Path

from ..regression.compare import Comparison
from .errors import TiltloadError, as_tiltload_errors
from .result import Result

Source = Result | str | Path


def _tolerance(name: str, value: float | None) -> float | None:
    from ...command_line.argument_types import tolerance
    from ..case.fields import named

    return None if value is None else named(tolerance, name, value)


def _load(source: Source, notes: list[str]) -> tuple[dict[str, float], dict, dict | None, str]:
    """(metrics, tolerances, case, name) of a Result, a log or a baseline file."""
    from ..regression.compare import load_case, load_metrics

    if isinstance(source, Result):
        return dict(source.metrics), {}, dict(source.record), str(source.log or "the run")
    if not isinstance(source, (str, Path)):
        raise TypeError(f"compare() takes a Result, a log (.mcap) or a baseline file (.json), got {type(source).__name__}")
    metrics, tolerances = load_metrics(Path(source), notes)
    return metrics, tolerances, load_case(Path(source)), str(source)


def compare(run: Source, baseline: Source, *, rtol: float | None = None, atol: float | None = None,
            any_case: bool = False) -> Comparison:
    """A run's metrics against a baseline's: each passes if |run - baseline| <= atol + rtol * |baseline|.

    run, baseline: a Result, a log (.mcap) or a metrics file (.json, as ``tiltload.save_baseline`` writes).
    rtol, atol: for every metric, in place of the baseline file's (default: its own, else 1e-6 and 1e-12).
    The two must be the same case (scenario, trajectory, controller, seed, stop time, --set, faults, wind, ...):
    else TiltloadError says in one line what differs, unless any_case. Returns a Comparison (``.ok``, ``.rows``,
    ``.table()``)."""
    from ..regression.compare import DEFAULT_ATOL, DEFAULT_RTOL, compare_cases, overridden
    from ..regression.compare import compare as compare_metrics

    rtol, atol = _tolerance("rtol", rtol), _tolerance("atol", atol)
    notes: list[str] = []
    with as_tiltload_errors():
        run_metrics, _, run_case, run_name = _load(run, notes)
        base, tol, base_case, base_name = _load(baseline, notes)
        what = compare_cases(run_case, base_case, run_name, base_name, any_case, notes)
        changes = _changes(run, baseline, run_case, base_case)
    ok, rows = compare_metrics(run_metrics, base, DEFAULT_RTOL, DEFAULT_ATOL, overridden(tol, rtol, atol))
    return Comparison(ok, rows, what, notes, changes)


def _fmus(source: Source) -> dict | None:
    """The FMUs' record (digests, parameters: engine.log.provenance) of a Result's log, a log or a baseline file."""
    from ..regression.changes import load_fmus

    path = source.log if isinstance(source, Result) else Path(source)
    return load_fmus(path) if path is not None and Path(path).is_file() else None


def _changes(run: Source, baseline: Source, run_case: dict | None, base_case: dict | None) -> list[str]:
    from ..regression.changes import between

    return between(_fmus(baseline), _fmus(run), base_case, run_case)


def save_baseline(result: Source, path: str | Path, *, rtol: float = 1e-6, atol: float = 1e-12) -> Path:
    """Write a run's metrics and case (a Result, or a run's log) as a baseline file (the format `tiltload compare` and
    `tiltload reproduce` read), with these tolerances for every metric."""
    import json

    rtol, atol = _tolerance("rtol", rtol), _tolerance("atol", atol)
    with as_tiltload_errors():
        path = _output(path, result)  # the place first: nothing is read for a baseline that cannot be written
    if isinstance(result, Result):
        metrics, record = dict(result.metrics), dict(result.record)
    elif isinstance(result, (str, Path)):
        from ..regression.compare import load_case, load_metrics

        with as_tiltload_errors():
            if Path(result).suffix != ".mcap":
                raise TiltloadError(f"{result}: a baseline is recorded from a run's log (.mcap)")
            metrics, _ = load_metrics(Path(result))
            record = load_case(Path(result)) or {}
    else:
        raise TypeError(f"save_baseline() takes a Result or a log (.mcap), got {type(result).__name__}")
    data = {"run": record, "metrics": metrics, "tolerances": {"rtol": rtol, "atol": atol}}
    fmus = _fmus(result)
    if fmus is not None:  # what ran, so that a failing comparison can say what changed
        data["fmus"] = fmus
    from ..output_folder import write_file

    with as_tiltload_errors():
        write_file(path, json.dumps(data, indent=1) + "\n")
    return path


def _output(path: object, source: Source) -> Path:
    """The baseline's path through the command's checks (output_folder.writable_file); the log it records is its
    input, never its output."""
    from ..output_folder import writable_file

    if not isinstance(path, (str, Path)):
        raise TypeError(f"path must be a str or a pathlib.Path, got {type(path).__name__}")
    if not str(path):
        raise TiltloadError("path: an empty path")
    log = source.log if isinstance(source, Result) else source
    return writable_file(Path(path), "path", {"the log it records": Path(log) if log is not None else None})

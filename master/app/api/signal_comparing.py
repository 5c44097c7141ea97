"""tiltload.compare_signals and tiltload.save_signal_baseline: a run's signals in tolerance tubes (docs/back_to_back.md)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import fields
from pathlib import Path

from ..regression.signal_compare import SignalComparison, Tolerances
from .errors import TiltloadError, as_tiltload_errors
from .result import Result

Source = Result | str | Path


def _log(source: Source, what: str) -> Path:
    if isinstance(source, Result):
        if source.log is None:
            raise TiltloadError(f"the {what} has no log (no_log=True): no signals to compare")
        return Path(source.log)
    if not isinstance(source, (str, Path)):
        raise TypeError(f"{what} must be a Result, a log (.mcap) or a signal baseline (.parquet), got {type(source).__name__}")
    return Path(source)


def _tolerances(tolerances: str | Path | Mapping | None) -> tuple[Tolerances | None, Path | None]:
    """(tolerances given as a mapping, or a tolerance file's path)."""
    from ..regression.signal_compare import parse_tolerances

    if tolerances is None or isinstance(tolerances, (str, Path)):
        return None, None if tolerances is None else Path(tolerances)
    if isinstance(tolerances, Mapping):
        return parse_tolerances(dict(tolerances), "tolerances"), None
    raise TypeError(f"tolerances must be a file or a mapping ({{'default': ..., 'signals': ...}}), got {type(tolerances).__name__}")


def compare_signals(run: Source, baseline: Source, *, signals: Sequence[str] | None = None,
                    tolerances: str | Path | Mapping | None = None, abs: float | None = None, rel: float | None = None,  # noqa: A002
                    lead: float | None = None, lag: float | None = None, any_case: bool = False) -> SignalComparison:
    """A run's signals against a baseline's, each inside its tolerance tube; the case first, what changed next.

    run: a Result or a log; baseline: a signal baseline (.parquet, as save_signal_baseline writes), a Result or a log.
    signals: "instance.variable" names (default: the tolerance's, else the baseline's). tolerances: a file (TOML,
    YAML, JSON) or a mapping {"default": {abs, rel, lead, lag}, "signals": {"plant.x": {...}}}; abs, rel, lead, lag
    replace that tolerance for every signal. Returns a SignalComparison (``.ok``, ``.rows``, ``.table()``,
    ``.report(baseline)``)."""
    from ..regression.signal_compare import compare_signal_files

    flags = {"abs": abs, "rel": rel, "lead": lead, "lag": lag}
    with as_tiltload_errors():
        mapping, file = _tolerances(tolerances)
        found = compare_signal_files(_log(run, "run"), _log(baseline, "baseline"), list(signals) if signals else None, file,
                                     flags, any_case, given=mapping)
    return Shown(**{f.name: getattr(found, f.name) for f in fields(found)})


class Shown(SignalComparison):
    """compare_signals' verdict (a tiltload.SignalComparison), shown in a notebook as a report: each signal in its tube,
    a figure of each signal outside."""

    def _repr_html_(self) -> str:
        from .rich_display import html_fragment, signal_comparison_report

        return html_fragment(signal_comparison_report(self))


def save_signal_baseline(result: Source, path: str | Path, signals: Sequence[str], *,
                         tolerances: str | Path | Mapping | None = None) -> Path:
    """These signals of a run (a Result or its log) as a signal baseline (.parquet): their samples, the case, every
    FMU's digest and parameters, and the tolerances a later comparison uses."""
    from ..regression.signal_compare import load_tolerances, record

    if isinstance(signals, str):
        signals = [signals]
    if not isinstance(path, (str, Path)):
        raise TypeError(f"path must be a str or a pathlib.Path, got {type(path).__name__}")
    if not str(path):
        raise TiltloadError("path: an empty path")
    with as_tiltload_errors():
        mapping, file = _tolerances(tolerances)
        tol = mapping if mapping is not None else load_tolerances(file) if file is not None else Tolerances()
        return record(_log(result, "run"), Path(path), list(signals), tol, {"the tolerance file": file})

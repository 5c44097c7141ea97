"""Assertions on runs for a user's tests (tiltload.testing): their failure messages read like a test report."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from ..api.comparing import compare
from ..api.errors import TiltloadError
from ..api.result import Result
from .report import baseline_report, limits_report, requirements_report

__tracebackhide__ = True


class TiltloadAssertionError(AssertionError):
    """A run that does not match its baseline or exceeds its limits; the message says which metric, by how much.
    comparison: the failing comparison where there was one (the pytest report shows its table and figures)."""

    def __init__(self, message: str, comparison: object = None) -> None:
        super().__init__(message)
        self.comparison = comparison


def assert_matches_baseline(result: Result, baseline: str | Path, *, rtol: float | None = None, atol: float | None = None,
                            update_hint: str | None = None) -> None:
    """The run's metrics within tolerance of the baseline file's (the same case, else the one line saying what differs).
    rtol, atol: in place of the baseline's own tolerances."""
    __tracebackhide__ = True
    try:
        comparison = compare(result, baseline, rtol=rtol, atol=atol)
    except TiltloadError as err:
        raise TiltloadAssertionError(f"{err}\n  rerun: {result.command}"
                                     + (f"\n  to record it again: {update_hint}" if update_hint else "")) from None
    if not comparison.ok:
        raise TiltloadAssertionError(baseline_report(comparison, result.record, result.command, baseline, update_hint=update_hint),
                                     comparison)


def assert_signals_match(result: Result, baseline: str | Path, *, signals=None, tolerances=None, update_hint: str | None = None,
                         **flags: float | None) -> None:
    """Each signal of the run inside its tolerance tube around the signal baseline's (tiltload.compare_signals: the same
    case, else the one line saying what differs). The message starts with what changed in the FMUs and their
    parameters, then names each signal outside: when it left first, by how much at most, for how long."""
    __tracebackhide__ = True
    from ..api.signal_comparing import compare_signals

    try:
        comparison = compare_signals(result, baseline, signals=signals, tolerances=tolerances, **flags)
    except TiltloadError as err:
        raise TiltloadAssertionError(f"{err}\n  rerun: {result.command}"
                                     + (f"\n  to record it again: {update_hint}" if update_hint else "")) from None
    if not comparison.ok:
        raise TiltloadAssertionError(comparison.report(baseline, result.command, update_hint=update_hint), comparison)


def assert_metrics_below(result: Result, limits: Mapping[str, float]) -> None:
    """Each named metric at most its limit (e.g. {"ISE(x)": 0.05})."""
    __tracebackhide__ = True
    message = limits_report(result.metrics, limits, result.record, result.command)
    if message is not None:
        raise TiltloadAssertionError(message)


def assert_requirements_hold(result: Result, requirements: str | Path | None = None, *, formulas=()) -> None:
    """Every requirement PASSes: those the run monitored (run with requirements=FILE), else those of the file and the
    formulas given here, checked on the run's log. The message names each that does not hold, its robustness, the
    time of its first violation and the signals there."""
    __tracebackhide__ = True
    from ..api.checking import check

    results = result.requirements if requirements is None and not formulas else check(result, requirements, formulas=formulas)
    if not results:
        raise TiltloadAssertionError(f"no requirement to check: run with requirements=FILE or name one here\n  rerun: {result.command}")
    message = requirements_report(results, result.record, result.command)
    if message is not None:
        raise TiltloadAssertionError(message)

"""The API's result objects in a notebook (their _repr_html_): each as the report its command writes, built here and
rendered by the reports' own page (evidence.page.html_fragment): the same evidence inline, no script, nothing fetched."""

from __future__ import annotations

import math
import tempfile
from pathlib import Path

from ..evidence.model import ERROR, FAIL, PASS, Report, Table, Test, environment_of_tests, png_uri, this_environment
from ..evidence.page import html_fragment

__all__ = ["back_to_back_report", "campaign_report", "check_report", "comparison_report", "html_fragment", "run_report",
           "signal_comparison_report"]


def run_report(result) -> Report:
    """A run's (tiltload.Result's) one-test report, as `tiltload run --report` writes it: its requirements, metrics, case,
    FMUs, replay command and standard figures."""
    from ..evidence import test_of_log

    if result.log is not None and Path(result.log).is_file():
        test = test_of_log(Path(result.log), list(result.requirements))
        test.command = result.command
    else:
        test = Test(result.record.get("name", "run"), result.command, dict(result.record), None, list(result.requirements),
                    dict(result.metrics))
    return Report(f"Run {test.name}", "run", [test], environment_of_tests([test], result.fmus))


def check_report(results, log: Path | None) -> Report:
    """`tiltload check`'s report of one log: each requirement's verdict, its first violation and its figure."""
    from ..evidence import test_of_log

    if log is not None and Path(log).is_file():
        test = test_of_log(Path(log), list(results))
    else:
        test = Test("requirements", results=list(results))
    return Report(f"Requirements on {test.name}", "check", [test], environment_of_tests([test]))


def comparison_report(comparison, title: str = "Metrics against the baseline") -> Report:
    """tiltload.compare's verdict as a one-test report: PASS or FAIL, the metric table, what changed in the FMUs."""
    bad = [r for r in comparison.rows if r.status != "ok"]
    failure = f"{len(bad)} of {len(comparison.rows)} metrics outside their tolerance: {', '.join(r.metric for r in bad)}" \
        if bad else None
    table = Table("Metrics", ("metric", "run", "baseline", "abs diff", "rel diff", "rtol", "atol", "status"), tuple(
        (r.metric, _g(r.run, 8), _g(r.baseline, 8), _g(r.abs_diff, 3), _g(r.rel_diff, 3), _g(r.rtol, 2), _g(r.atol, 2),
         r.status) for r in comparison.rows), "Each metric passes if |run - baseline| <= atol + rtol * |baseline|.")
    return Report(title, "comparison", [Test("the run against its baseline", outcome=PASS if comparison.ok else FAIL,
                                             failure=failure)],
                  this_environment(), tables=[table], summary=_said(comparison))


def signal_comparison_report(comparison) -> Report:
    """tiltload.compare_signals' verdict: each signal in its tube, a figure of each signal outside."""
    return _tubes_report("Signals against the baseline", [("the run against its signal baseline", comparison.rows, None)],
                         _said(comparison))


def back_to_back_report(b2b) -> Report:
    """tiltload.b2b's verdict: a test per case (ERROR: a side that did not run to its end), each signal's tube, a figure
    of each signal outside."""
    said = "; ".join(b2b.changes) if b2b.changes else "what changed: nothing in the FMUs or their parameters"
    return _tubes_report("Back to back", [(r.name, r.rows, r.error) for r in b2b.results], said)


def _tubes_report(title: str, cases: list[tuple[str, list, str | None]], summary: str) -> Report:
    from ..regression.tube_plot import tube_figures

    tests, rows, figures = [], [], []
    with tempfile.TemporaryDirectory(prefix="tl-tubes-") as folder:
        for k, (name, signals, error) in enumerate(cases):
            bad = [r for r in signals if not r.passed]
            tests.append(Test(name, outcome=ERROR if error else PASS if not bad else FAIL, error=error,
                              failure="; ".join(f"{r.signal}: {r.words()}" for r in bad) or None))
            rows += [(name, r.signal, r.status, "-" if r.passed else f"{r.first_outside:.6g}",
                      "-" if r.passed else f"{r.largest_excess:.4g}", f"{100 * r.share_outside:.3g}", r.tolerance.words())
                     for r in signals]
            figures += [(p.stem.replace("_", " "), png_uri(p)) for p in tube_figures(signals, Path(folder), f"case{k}", name)]
    table = Table("Signals in their tolerance tubes", ("case", "signal", "status", "first out (s)", "largest excess",
                                                        "out %", "tolerance"), tuple(rows))
    return Report(title, "comparison", tests, this_environment(), figures=figures, tables=[table], summary=summary)


def campaign_report(results: Path) -> Report:
    """A campaign's report (its report.html) from its results file."""
    from ..campaign.report import page

    return page(Path(results))


def _said(comparison) -> str:
    lines = [comparison.changed_line() or "", *comparison.notes]  # the notes name the cases' differences
    return "; ".join(line for line in lines if line)


def _g(x: float, digits: int) -> str:
    return f"{x:.{digits}g}" if isinstance(x, (int, float)) and not math.isnan(x) else "-"


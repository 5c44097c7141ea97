"""The pytest plugin's report (--tiltload-report FILE): a section per test, with the runs it made through the
tiltload_run fixture (their requirements judged, their logs' figures) and its own outcome."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from .model import ERROR, FAIL, PASS, BaselineOutcome, Report, Test, environment_of_log, environment_of_tests

__all__ = ["BaselineOutcome", "TestRecord", "tests_of", "write_pytest_report"]
from .page import write_report


@dataclass
class TestRecord:
    """What one pytest test did: its runs (tiltload.Result), its baselines' checks (BaselineOutcome) and its outcome
    with the failure's first line."""

    nodeid: str
    runs: list = field(default_factory=list)
    outcome: str | None = None  # PASS, FAIL (the test body failed), ERROR (its set-up or tear-down failed)
    failure: str | None = None
    baselines: list = field(default_factory=list)


def tests_of(records: list[TestRecord]) -> list[Test]:
    tests = []
    for rec in records:
        error = rec.failure if rec.outcome == ERROR else None
        failure = rec.failure if rec.outcome == FAIL else None
        if not rec.runs:
            tests.append(Test(rec.nodeid, outcome=rec.outcome, error=error, failure=failure, baselines=list(rec.baselines)))
            continue
        for k, run in enumerate(rec.runs):
            name = rec.nodeid if len(rec.runs) == 1 else f"{rec.nodeid} (run {k + 1})"
            tests.append(Test(name, run.command, dict(run.record), run.log, list(run.requirements), dict(run.metrics),
                              error=error, outcome=rec.outcome, failure=failure, environment=_environment(run.log),
                              baselines=list(rec.baselines) if k == len(rec.runs) - 1 else []))  # once, by its last run
    return tests


def _environment(log):
    """The FMUs a run's log records (its "fmus" metadata): the report's first screen names the controller by them."""
    from ...engine.log.reader import read_metadata

    return environment_of_log(read_metadata(Path(log))) if log and Path(log).is_file() else None


def write_pytest_report(records: list[TestRecord], path: Path, title: str) -> Path:
    counts = {o: sum(1 for r in records if r.outcome == o) for o in (PASS, FAIL, ERROR)}
    summary = f"{len(records)} tests: {counts[PASS]} passed, {counts[FAIL]} failed, {counts[ERROR]} errors."
    tests = tests_of(records)
    return write_report(Report(title, "pytest", tests, environment_of_tests(tests), summary=summary), path)

"""What a report holds: tests (one run or log each, and the requirements judged on it), the environment, the summary
counts and the requirement traceability matrix. Plain data: the page (page.py) and the JSON are drawn from it."""

from __future__ import annotations

import hashlib
import platform
import sys
from dataclasses import dataclass, field
from pathlib import Path

from ..case.record import FmuRecord, fmus_of_metadata, fmus_of_system

# a cell of the traceability matrix, and what the summary counts
PASS, VACUOUS, FAIL, INCONCLUSIVE, ZERO, ERROR, NOT_EXERCISED = (
    "PASS", "PASS (vacuous)", "FAIL", "INCONCLUSIVE", "ZERO", "ERROR", "not exercised")
COUNTED = (PASS, FAIL, INCONCLUSIVE, VACUOUS, ZERO, ERROR)


@dataclass(frozen=True)
class Environment:
    """Where the evidence was made: the tiltload version, Python, the platform, the FMUs and the controller's
    parameters (name -> value as the run set them, else its FMU's start value)."""

    tiltload: str
    python: str
    platform: str
    fmus: tuple[FmuRecord, ...] = ()
    controller_parameters: tuple[tuple[str, str], ...] = ()

    def to_json(self) -> dict:
        return {"tiltload": self.tiltload, "python": self.python, "platform": self.platform,
                "fmus": [vars(f) for f in self.fmus], "controller_parameters": dict(self.controller_parameters)}


@dataclass
class Test:
    """One test or case: what ran (its replay command), its log, its metrics, each requirement's result
    (engine.requirement.check.Result), and the one line of a run that ended in an error."""

    name: str
    command: str = ""
    case: dict = field(default_factory=dict)  # the log's "run" record: the case as it ran
    log: Path | None = None
    results: list = field(default_factory=list)
    metrics: dict[str, float] = field(default_factory=dict)
    error: str | None = None
    environment: Environment | None = None  # a test's own, where the tests ran on different FMUs (else the report's)
    outcome: str | None = None  # the test's own verdict (a pytest test: PASS, FAIL, ERROR), counted if it judged no requirement
    failure: str | None = None  # why a test failed (its assertion's first line): not an error of its run
    baselines: list = field(default_factory=list)  # BaselineOutcome: each baseline the test checked, a failing one's tables


@dataclass(frozen=True)
class BaselineOutcome:
    """A test's check of a recorded baseline: what (metrics, signals), its file, the outcome (PASS, FAIL, recorded, none
    recorded); a FAIL's tables (the metric table, the signals' tubes) and figures (title, data: URI)."""

    what: str
    file: str
    outcome: str
    tables: tuple = ()
    figures: tuple = ()


@dataclass(frozen=True)
class Table:
    """A table of the report's own (a campaign's pass rates, its worst runs): a title, a header and rows of text."""

    title: str
    header: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]
    note: str = ""


@dataclass
class Report:
    """The tests of one report, under a title; `declared` lists the requirements that should have been checked (those
    of the requirement files), so that one no test checked shows as not exercised. `figures` (title, data: URI) and
    `tables` are the report's own (a campaign's maps, a search's convergence), shown before the tests."""

    title: str
    kind: str  # run, check, campaign, falsification, pytest
    tests: list[Test]
    environment: Environment
    declared: list = field(default_factory=list)  # engine.requirement.files.Requirement
    figures: list[tuple[str, str]] = field(default_factory=list)
    tables: list[Table] = field(default_factory=list)
    summary: str = ""  # a paragraph under the title
    listed: int | None = None  # the most tests the page shows one by one (the counts are over all): a page stays readable


def verdict_of(result) -> str:
    """A requirement result's cell: its verdict, PASS (vacuous) for a vacuous pass."""
    if result.verdict == PASS and getattr(result, "vacuous", False):
        return VACUOUS
    return result.verdict


def requirement_ids(report: Report) -> list[tuple[str, str]]:
    """(name, source) of every requirement in the report: the declared ones first, in their order, then any other a
    test judged."""
    seen: dict[str, str] = {}
    for req in report.declared:
        seen.setdefault(req.name, getattr(req, "source", ""))
    for test in report.tests:
        for r in test.results:
            seen.setdefault(r.name, r.source)
    return list(seen.items())


def matrix(report: Report) -> dict[str, dict[str, str]]:
    """Requirement -> test -> cell: its verdict; ERROR where the test's run failed before judging it; not exercised
    where the test did not check it."""
    out: dict[str, dict[str, str]] = {}
    for name, _ in requirement_ids(report):
        row = out[name] = {}
        for test in report.tests:
            result = next((r for r in test.results if r.name == name), None)
            row[test.name] = verdict_of(result) if result is not None else ERROR if test.error else NOT_EXERCISED
    return out


def counts(report: Report) -> dict[str, int]:
    """How many cells of the matrix are PASS, FAIL, INCONCLUSIVE, vacuous PASS and ZERO; ERROR counts the tests whose
    run ended in an error (once each, whatever their cells); a test that judged no requirement and ran to its end
    counts once by its own outcome (a pytest test's PASS or FAIL)."""
    tally = dict.fromkeys(COUNTED, 0)
    for row in matrix(report).values():
        for cell in row.values():
            if cell in tally and cell != ERROR:
                tally[cell] += 1
    for t in report.tests:
        if t.error or t.outcome == ERROR:
            tally[ERROR] += 1
        elif not t.results and t.outcome in tally:
            tally[t.outcome] += 1
    return tally


def png_uri(path: Path) -> str:
    """A PNG file as a data: URI, for a figure already written beside the results."""
    import base64

    return "data:image/png;base64," + base64.b64encode(Path(path).read_bytes()).decode()


def this_environment(fmus=(), controller_parameters=()) -> Environment:
    from ....native_fmu.build import tiltload_version

    return Environment(tiltload_version(), sys.version.split()[0], platform.platform(), tuple(fmus), tuple(controller_parameters))


def sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def environment_of_system(system) -> Environment:
    """The environment of a run of `system` (engine.system.System): each instance's FMU (model, GUID, digest) and the
    controller instance's parameters (its FMU's start values, overridden by what the run set): case/record.py."""
    return this_environment(*fmus_of_system(system))


def environment_of_log(metadata: dict) -> Environment | None:
    """The environment a log's record names (its "fmus" metadata); None for a log without one."""
    fmus, parameters = fmus_of_metadata(metadata.get("fmus", {}) if isinstance(metadata.get("fmus"), dict) else {})
    return this_environment(fmus, parameters) if fmus else None


def environment_of_tests(tests: list[Test], fmus=(), controller_parameters=()) -> Environment:
    """A report's environment: the FMUs its tests' records name when every test that has one names the same (each test
    keeps its own where they differ, and the page shows them by test); else the FMUs given (a campaign's: its spec's)."""
    known = [t.environment for t in tests if t.environment is not None and t.environment.fmus]
    if known and all(e.fmus == known[0].fmus and e.controller_parameters == known[0].controller_parameters for e in known):
        return known[0]
    return this_environment(fmus, controller_parameters)

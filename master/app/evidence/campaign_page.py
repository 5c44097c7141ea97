"""A campaign's results as a report: a test per run (its rerun command, its varied values, metrics and the verdicts
of keep.requirements), the pass rate of each requirement, the worst runs, and the campaign's figures inline."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

from ..case.verdict_counts import requirement_counts, requirement_names
from .model import Report, Table, Test, environment_of_tests, png_uri
from .page import write_report


@dataclass(frozen=True)
class StoredVerdict:
    """A requirement's verdict as a campaign row keeps it (NAME_verdict, NAME_robustness, NAME_first_violation and
    NAME_values: its first violation and the signals there)."""

    name: str
    verdict: str
    robustness: float | None
    vacuous: bool = False
    first_violation: float | None = None
    formula: str = ""
    source: str = ""
    description: str = ""
    why: str = ""
    values: dict = field(default_factory=dict)


def _number(x) -> float | None:
    try:
        x = float(x)
    except (TypeError, ValueError):
        return None
    return x if math.isfinite(x) else None


def _stored(name: str, row: dict, formulas: dict[str, str], sources: dict[str, str]) -> StoredVerdict:
    """A requirement's stored verdict; the column says "PASS (vacuous)" for a vacuous pass."""
    shown = str(row[f"{name}_verdict"])
    vacuous = shown.endswith("(vacuous)")
    try:  # an older results file has no such column
        values = {k: _number(v) for k, v in json.loads(row.get(f"{name}_values") or "{}").items()}
    except (TypeError, ValueError, AttributeError):
        values = {}
    return StoredVerdict(name, shown.split(" ")[0] if vacuous else shown, _number(row[f"{name}_robustness"]), vacuous,
                         _number(row.get(f"{name}_first_violation")), formulas.get(name, ""), sources.get(name, ""),
                         values=values)


def _test(row: dict, varied: list[str], names: list[str], command: str, formulas: dict[str, str],
          sources: dict[str, str]) -> Test:
    failed = bool(row.get("error")) or not row.get("completed", True)
    results = [] if failed else [_stored(n, row, formulas, sources) for n in names]
    metrics = {k: v for k, v in row.items() if k.startswith(("ISE(", "IADU(")) or k in (
        "max_tracking_error", "time_saturated", "zse_containment")}
    case = {"controller": row.get("controller"), "seed": row.get("seed"), **{k: row.get(k) for k in varied}}
    error = (row.get("error") or "the run did not complete") if failed else None
    return Test(f"run {row.get('run_id')}", command, case, None, results, {k: _number(v) for k, v in metrics.items()}, error)


LISTED = 500  # runs the page shows one by one
FIRST_VIOLATIONS = 20  # failed requirements the summary's table lists (every run's own section lists its own)


def write_campaign_report(name: str, rows: list[dict], varied: list[str], commands: list[str], figures: list[Path],
                          out: Path, formulas: dict[str, str] | None = None, fmus=(), controller_parameters=(),
                          requirements=()) -> Path:
    """report.html of a campaign's rows (campaign_report's arguments)."""
    return write_report(campaign_report(name, rows, varied, commands, figures, formulas, fmus, controller_parameters,
                                        requirements), Path(out), standard_figures=False)


def campaign_report(name: str, rows: list[dict], varied: list[str], commands: list[str], figures: list[Path],
                    formulas: dict[str, str] | None = None, fmus=(), controller_parameters=(), requirements=()) -> Report:
    """The report of a campaign's rows (commands[i] reruns rows[i]; figures: the PNGs written beside the results;
    fmus, controller_parameters: what the campaign ran, case.record's FmuRecords; requirements: keep.requirements'
    file, loaded, for each requirement's formula and source)."""
    names = requirement_names(rows[0]) if rows else []
    formulas = (formulas or {}) | {r.name: r.text for r in requirements}
    sources = {r.name: r.source for r in requirements}
    tests = [_test(r, varied, names, c, formulas, sources) for r, c in zip(rows, commands)]
    tables = []
    if names:  # the counts every face prints (case.verdict_counts): a failed or diverged run is ERROR
        body = []
        for t in requirement_counts(rows):
            c = t.counts
            body.append((t.name, str(c["PASS"] - t.vacuous), str(t.vacuous), str(c["FAIL"]), str(c["INCONCLUSIVE"]),
                         str(c["ZERO"]), str(c["ERROR"]), f"{100 * t.pass_rate:.0f} %",
                         "—" if t.least_robustness is None else f"{t.least_robustness:.4g}"))
        tables.append(Table("Pass rate per requirement", ("requirement", "PASS", "PASS (vacuous)", "FAIL", "INCONCLUSIVE",
                                                          "ZERO", "ERROR", "pass rate", "least robustness"),
                            tuple(body), "A run that failed or diverged judged no requirement: it counts as ERROR."))
    failing = sorted(((r.robustness if r.robustness is not None else -math.inf, i, r) for i, t in enumerate(tests)
                      for r in t.results if r.verdict == "FAIL"), key=lambda x: (x[0], x[1]))
    if failing:  # the signed-off reading of a FAIL: when it first broke and what the signals were there
        tables.append(Table("First violations", ("run", "requirement", "first violation (s)", "signals there", "rerun"), tuple(
            (str(rows[i].get("run_id")), r.name, "—" if r.first_violation is None else f"{r.first_violation:.6g}",
             ", ".join(f"{k} = {'—' if v is None else f'{v:.6g}'}" for k, v in r.values.items()) or "—", commands[i])
            for _, i, r in failing[:FIRST_VIOLATIONS]),
            "The failed requirements of the runs, least robust first"
            + (f" (the first {FIRST_VIOLATIONS} of {len(failing)})." if len(failing) > FIRST_VIOLATIONS else ".")))
    worst = sorted(range(len(rows)), key=lambda i: (not tests[i].error, -(_number(rows[i].get("max_tracking_error")) or 0.0)))[:10]
    tables.append(Table("Worst runs", ("run", "controller", "seed", *varied, "outcome", "rerun"), tuple(
        (str(rows[i].get("run_id")), str(rows[i].get("controller")), str(rows[i].get("seed")),
         *(f"{_number(rows[i].get(k)) or 0:.4g}" for k in varied),
         tests[i].error or f"max tracking error {_number(rows[i].get('max_tracking_error')) or math.nan:.3g} m", commands[i])
        for i in worst), "Failed or diverged runs first, then the largest tracking error."))
    completed = sum(1 for t in tests if not t.error)
    summary = (f"{len(rows)} runs, {completed} completed without an error; varied: {', '.join(varied) or 'seeds only'}; "
               f"controllers: {', '.join(dict.fromkeys(str(r.get('controller')) for r in rows))}.")
    # the page lists LISTED runs one by one, the failed or diverged first, then those that failed a requirement, then
    # in run order: a page of 20,000 runs was 35 MB and took the client 450 MB to write; results.parquet has them all
    order = sorted(range(len(tests)), key=lambda i: (not tests[i].error, not any(r.verdict == "FAIL" for r in tests[i].results), i))
    if len(tests) > LISTED:
        summary += (f" The page lists {LISTED} of the {len(tests)} runs one by one: the failed or diverged first, then those "
                    "that failed a requirement, then in run order; results.parquet holds every run.")
    environment = environment_of_tests(tests, fmus, controller_parameters)  # the rows hold no FMUs: fmus.json's
    return Report(f"Campaign {name}", "campaign", [tests[i] for i in order], environment, declared=list(requirements),
                  listed=LISTED, figures=[(p.stem.replace("_", " "), png_uri(p)) for p in figures if Path(p).is_file()],
                  tables=tables, summary=summary)

"""The verdicts of a case set's runs, counted once: every face (the terminal, the API's result, report.md, report.html)
prints these counts, so no two of them can disagree.

A run that failed or diverged judged nothing: each of its requirements is ERROR (the row's `error` says why and
`diverged_at` when), never FAIL with the NaN robustness the unfinished trace left, whatever an older results file
stored in its verdict column.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

ERROR = "ERROR"
VERDICTS = ("PASS", "FAIL", "INCONCLUSIVE", "ZERO", ERROR)


def requirement_names(row: dict) -> list[str]:
    """The requirements a row judges: its NAME_verdict and NAME_robustness column pairs."""
    return [k[:-len("_verdict")] for k in row if k.endswith("_verdict") and f"{k[:-8]}_robustness" in row]


COLUMNS = ("verdict", "robustness", "first_violation", "values")  # a requirement's columns: NAME_verdict, ...


def requirement_columns(row: dict) -> set[str]:
    """Every column of a row that belongs to a requirement (COLUMNS of each of requirement_names)."""
    return {f"{n}_{c}" for n in requirement_names(row) for c in COLUMNS} & set(row)


def run_failed(row: dict) -> bool:
    """A run that did not complete, or ended with an error (a divergence among them)."""
    return bool(row.get("error")) or not row.get("completed", True)


def row_verdict(row: dict, name: str) -> tuple[str, bool, float | None]:
    """(verdict, vacuous, finite robustness or None) of one requirement in one row."""
    if run_failed(row):
        return ERROR, False, None
    shown = str(row.get(f"{name}_verdict") or "INCONCLUSIVE")
    vacuous = shown.endswith("(vacuous)")
    try:
        robustness = float(row.get(f"{name}_robustness"))
    except (TypeError, ValueError):
        robustness = math.nan
    return shown.split(" ")[0], vacuous, robustness if math.isfinite(robustness) else None


@dataclass(frozen=True)
class RequirementCount:
    """One requirement over a case set's runs: how many runs gave each verdict (vacuous: the PASSes whose trigger never
    held), and the least robustness of the runs that judged it (None: none did)."""

    name: str
    runs: int
    counts: dict[str, int]
    vacuous: int
    least_robustness: float | None

    @property
    def pass_rate(self) -> float:
        return self.counts["PASS"] / self.runs if self.runs else 0.0

    def line(self) -> str:
        """The one line the terminal prints."""
        said = ", ".join(f"{self.counts[v]} {v}" for v in VERDICTS)
        least = "—" if self.least_robustness is None else f"{self.least_robustness:.4g}"
        return f"requirement {self.name}: {said} (of {self.runs} runs); least robustness {least}"


def requirement_counts(rows: list[dict]) -> list[RequirementCount]:
    """Each requirement's counts over the rows (in the order of the rows' columns)."""
    out = []
    for name in requirement_names(rows[0]) if rows else []:
        counts = dict.fromkeys(VERDICTS, 0)
        vacuous, robust = 0, []
        for row in rows:
            verdict, empty, robustness = row_verdict(row, name)
            counts[verdict] = counts.get(verdict, 0) + 1
            vacuous += empty
            if robustness is not None:
                robust.append(robustness)
        out.append(RequirementCount(name, len(rows), counts, vacuous, min(robust, default=None)))
    return out


def counts_of_results(results: Path) -> list[RequirementCount]:
    """requirement_counts of a results file's rows (only the columns they read)."""
    import pyarrow.parquet as pq

    names = pq.read_schema(results).names
    keep = [k for k in names if k in ("completed", "error") or k.endswith(("_verdict", "_robustness"))]
    return requirement_counts(pq.read_table(results, columns=keep).to_pylist()) if keep else []

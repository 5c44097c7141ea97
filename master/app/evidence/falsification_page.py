"""A falsification's report.html: the search (its space, budget, convergence), the counterexample (or the least robust
case) replayed with a log, each requirement on it with its bound drawn and the violation shaded, the neighbourhood."""

from __future__ import annotations

import math
from pathlib import Path

from .model import Report, Table, environment_of_tests, png_uri
from .page import write_report
from .tests_from_logs import test_of_log


def simulations(n: int) -> str:
    """n simulations, as every line of a search says it: "1 simulation", "40 simulations"."""
    return f"{n} simulation{'' if n == 1 else 's'}"


def write_falsification_report(name: str, summary: str, requirements: list, dimensions: list[tuple[str, str, float, float]],
                               rows: list[dict], falsified_at: int | None, replay: list[str] | None, log: Path | None,
                               figures: list[Path], out: Path) -> Path:
    """report.html in out (falsification_report's arguments)."""
    return write_report(falsification_report(name, summary, requirements, dimensions, rows, falsified_at, replay, log, figures),
                        Path(out) / "report.html")


def falsification_report(name: str, summary: str, requirements: list, dimensions: list[tuple[str, str, float, float]],
                         rows: list[dict], falsified_at: int | None, replay: list[str] | None, log: Path | None,
                         figures: list[Path]) -> Report:
    """A search's report (report.html in its folder; a notebook's display of tiltload.falsify): dimensions (name,
    target, low, high); rows the evaluations in order; replay the command that replays the best case and log that
    replay's log (None: no case had a robustness)."""
    import shlex

    from ...engine.requirement.check import check_log

    tests = []
    if log is not None and Path(log).is_file():
        test = test_of_log(Path(log), check_log(Path(log), requirements, missing="inconclusive"), name="counterexample"
                           if falsified_at is not None else "least robust case")
        test.command = shlex.join(replay) if replay else test.command
        tests.append(test)
    best = min((r for r in rows if _finite(r.get("robustness"))), key=lambda r: r["robustness"], default=None)
    space = Table("Search space", ("dimension", "target", "low", "high", "best case"), tuple(
        (n, t, f"{lo:g}", f"{hi:g}", f"{best[n]:.6g}" if best is not None and n in best else "—") for n, t, lo, hi in dimensions))
    found = f"falsified after {simulations(falsified_at + 1)}" if falsified_at is not None else \
        f"not falsified in {simulations(len(rows))} (a search is no proof)"
    search = Table("The search", ("simulations", "outcome", "least robustness"), (
        (str(len(rows)), found, f"{best['robustness']:.6g}" if best is not None else "—"),))
    return Report(f"Falsification {name}", "falsification", tests, environment_of_tests(tests), declared=list(requirements),
                  figures=[(Path(p).stem.replace("_", " "), png_uri(p)) for p in figures if Path(p).is_file()],
                  tables=[search, space], summary=summary.splitlines()[0] if summary else "")


def _finite(x) -> bool:
    return x is not None and isinstance(x, (int, float)) and math.isfinite(x)

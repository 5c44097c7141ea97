"""tiltload.check: `tiltload check` from Python: each requirement's verdict on a run's log."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

from ...engine.requirement.check import Result as RequirementResult
from .errors import TiltloadError, as_tiltload_errors
from .result import Result


class Verdicts(list):
    """check's results: a list of each requirement's result, shown in a notebook as `tiltload check --report`'s
    report of the log (each verdict, its first violation, its figure)."""

    def __init__(self, results: Iterable[RequirementResult], log: Path | None = None) -> None:
        super().__init__(results)
        self.log = log

    def _repr_html_(self) -> str:
        from .rich_display import check_report, html_fragment

        return html_fragment(check_report(self, self.log))


def check(run: Result | str | Path, requirements: str | Path | None = None, *, formulas: Iterable[str] = ()
          ) -> list[RequirementResult]:
    """The verdicts of a requirement file (YAML, docs/requirements.md) and of one-off formulas ("NAME: STL", as
    `tiltload check --formula` takes them) on a run (a Result of tiltload.run, or an MCAP log's path).

    Each result has name, verdict (PASS, FAIL, INCONCLUSIVE, ZERO), vacuous (a PASS whose trigger never held), robustness,
    first_violation (s) and the signals' values there; to_json() is valid JSON. Raises TiltloadError for a missing or
    damaged log, a formula that does not parse or exceeds a limit, an unknown signal, a window past the run's end."""
    from ...engine.requirement.files import from_option, load

    log = run.log if isinstance(run, Result) else Path(run)
    if log is None:
        raise TiltloadError("the run has no log (no_log=True): nothing to check")
    with as_tiltload_errors():
        reqs = [*(load(Path(requirements)) if requirements is not None else []), *(from_option(f) for f in formulas)]
        if not reqs:
            raise TiltloadError("check: name a requirement file or give formulas")
        from ...engine.requirement.check import check_log, log_span
        from ...engine.requirement.files import check_horizons

        if Path(log).is_file():  # as `tiltload check` refuses it: a window past the run's end can never be decided
            check_horizons(reqs, log_span(log), f"the run in {Path(log).name}")
        return Verdicts(check_log(log, reqs), Path(log))

"""tiltload.campaign: a campaign spec run with its CampaignOptions by the same core as `tiltload campaign SPEC`."""

from __future__ import annotations

import shlex
from collections.abc import Callable
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import TYPE_CHECKING

from ..campaign.options import CAMPAIGN
from ..loop.defaults import FMU_DIR, WORKER_TIMEOUT
from . import field_types as kinds
from .command_line import options_argv
from .errors import TiltloadError, as_tiltload_errors
from .field_types import closest_field

if TYPE_CHECKING:
    import pandas as pd

    from ..case.verdict_counts import RequirementCount



@closest_field
@dataclass(frozen=True, kw_only=True)
class CampaignOptions:
    """How a campaign runs, field names as `tiltload campaign`'s options: out (default runs/campaigns/<name>), the FMU
    folder, an existing Dask scheduler or a local cluster of workers, how patiently, what again."""

    out: Path | None = None
    scheduler: str | None = None  # tcp://HOST:PORT or tls://HOST:PORT; None: a local cluster
    workers: int | None = None  # the local cluster's size; with a scheduler, how many to wait for
    connect_timeout: float = 5.0  # s
    worker_timeout: float = WORKER_TIMEOUT  # s
    retries: int = 2  # further tries of a run whose environment failed
    retry_failed: bool = False  # run again the stored runs that failed
    verbose: bool = False  # Dask's log on the terminal too
    fmus: Path = FMU_DIR

    def __post_init__(self) -> None:
        owner, fix = "CampaignOptions", self._fix
        fix("out", kinds.path(owner, "out", self.out))
        fix("fmus", kinds.path(owner, "fmus", self.fmus, False))
        kinds.text(owner, "scheduler", self.scheduler)
        if fix("workers", kinds.whole(owner, "workers", self.workers)) is not None:
            CAMPAIGN.check("workers", self.workers)  # the campaign's field types (campaign/options.py), as its parser
        for name in ("connect_timeout", "worker_timeout"):
            fix(name, kinds.number(owner, name, getattr(self, name), False))
            fix(name, CAMPAIGN.check(name, getattr(self, name)))
        retries = fix("retries", kinds.whole(owner, "retries", self.retries, False))
        CAMPAIGN.check("retries", retries)
        kinds.flag(owner, "retry_failed", self.retry_failed)
        kinds.flag(owner, "verbose", self.verbose)

    def _fix(self, name: str, value: object) -> object:
        object.__setattr__(self, name, value)  # frozen: normalized once, while built
        return value


@dataclass(frozen=True)
class CampaignResult:
    """A campaign's results file and what it holds: total (the spec's runs), stored, completed, failed, diverged,
    skipped (stored before), ran (stored now); requirements: each requirement's verdict counts, as the terminal and the
    reports print them (a failed or diverged run is ERROR)."""

    results: Path
    counts: dict[str, int]
    command: str
    requirements: tuple[RequirementCount, ...] = ()

    def to_dataframe(self) -> pd.DataFrame:
        """One row per run: its parameters, metrics and state."""
        import pandas as pd

        return pd.read_parquet(self.results)


def run_campaign(spec: Path, options: CampaignOptions, progress: Callable[[str], None] | None = None) -> tuple[Path, dict]:
    """The core of `tiltload campaign SPEC` and tiltload.campaign: (results file, counts). progress: where the
    campaign's lines go (default stderr). CampaignIncomplete when runs are still missing at the end."""
    from ..batch.errors import ClusterError
    from ..campaign.runner import run
    from ..user_error import UserError

    how = {f.name: getattr(options, f.name) for f in fields(options) if f.name not in ("out", "fmus")}
    report_beside(spec, options.out)
    try:
        results, counts = run(Path(spec), options.out, options.fmus, progress=progress, **how)
    except ClusterError as err:
        raise UserError(str(err)) from None
    _report(Path(results), progress)
    return results, counts


def report_beside(spec: Path, out: Path | None) -> None:
    """The report.html a campaign or search writes into its folder must not be its spec: refused before it runs."""
    from ..output_folder import same_file
    from ..user_error import UserError

    if out is not None and Path(spec).exists() and same_file(Path(out) / "report.html", Path(spec)):
        raise UserError(f"--out {out}: its report.html is the spec ({spec}): refused, it would be written over")


def _report(results: Path, progress: Callable[[str], None] | None) -> None:
    """The campaign's report beside its results (report.md, its figures, report.html); results it cannot report are
    said in one line, the results kept."""
    import sys

    from ..campaign.report import ReportError, report, written

    say = progress or (lambda line: print(line, file=sys.stderr))
    try:
        path = report(results)
    except ReportError as err:
        say(f"report: none ({err})")
        return
    say(written(path))


def campaign(spec: str | Path, options: CampaignOptions | None = None, /, *, progress: Callable[[str], None] | None = None,
             **keywords: object) -> CampaignResult:
    """Run what is missing of a campaign spec (TOML/YAML: docs/campaigns.md) as `tiltload campaign SPEC` does; its
    options a CampaignOptions or keywords (out=, workers=, scheduler=, retries=, fmus=, ...). A campaign that ends with
    runs still missing raises TiltloadError (the results hold the others)."""
    from ..batch.errors import CampaignIncomplete
    from ..case.verdict_counts import counts_of_results

    if not isinstance(spec, (str, Path)):
        raise TypeError(f"campaign() takes the spec's path (str or pathlib.Path), got {type(spec).__name__}")
    if str(spec) == "report":
        raise TiltloadError("campaign: 'report' is not a spec (the report is `tiltload campaign-report RESULTS`)")
    known = {f.name for f in fields(CampaignOptions)}
    for key in keywords:
        if key not in known:
            raise TypeError(f"campaign() got an unexpected keyword argument {key!r}; the options are {', '.join(sorted(known))}")
    given = {k: v for k, v in keywords.items() if v is not None}
    with as_tiltload_errors():
        options = replace(options, **given) if options is not None else CampaignOptions(**given)
        try:
            results, counts = run_campaign(Path(spec), options, progress)
        except CampaignIncomplete as err:
            raise TiltloadError(str(err)) from None
    command = shlex.join(["tiltload", "campaign", Path(spec).as_posix(), *options_argv(options)])
    return CampaignResult(Path(results), dict(counts), command, tuple(counts_of_results(Path(results))))

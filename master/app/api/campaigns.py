"""tiltload.campaign: `tiltload campaign SPEC` from Python, the same options as keywords."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from . import keywords
from .errors import TiltloadError, as_tiltload_errors

if TYPE_CHECKING:
    import pandas as pd


@dataclass(frozen=True)
class CampaignResult:
    """A campaign's results file and what it holds: total (the spec's runs), stored, completed, failed, diverged,
    skipped (stored before), ran (stored now)."""

    results: Path
    counts: dict[str, int]
    command: str

    def to_dataframe(self) -> pd.DataFrame:
        """One row per run: its parameters, metrics and state."""
        import pandas as pd

        return pd.read_parquet(self.results)


def campaign(spec: str | Path, **options: object) -> CampaignResult:
    """Run what is missing of a campaign spec (TOML/YAML: docs/campaigns.md) as `tiltload campaign SPEC` does, its
    options as keywords (out=, workers=, scheduler=, retries=, fmus=, ...). A campaign that ends with runs still
    missing raises TiltloadError (the results hold the others)."""
    from ..campaign.errors import CampaignIncomplete
    from ..commands.campaign import execute

    if str(spec) == "report":
        raise TiltloadError("campaign: 'report' is not a spec (the report is `tiltload campaign report RESULTS`)")
    argv = [str(spec), *keywords.to_argv("campaign", options, "campaign")]
    args = keywords.parse("campaign", argv)
    with as_tiltload_errors():
        try:
            results, counts = execute(args)
        except CampaignIncomplete as err:
            raise TiltloadError(str(err)) from None
    return CampaignResult(Path(results), dict(counts), keywords.command_line("campaign", argv))

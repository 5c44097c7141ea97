"""`tiltload campaign SPEC` runs a campaign on Dask; `tiltload campaign report RESULTS` summarizes one."""

from __future__ import annotations

import argparse
from pathlib import Path

from .. import arguments
from ..errors import UserError


def add_parser(sub) -> None:
    ca = sub.add_parser("campaign", help="run a campaign spec on Dask (TOML/YAML), or 'report RESULTS' to summarize one")
    ca.add_argument("what", help="the campaign spec, or 'report'")
    ca.add_argument("results", nargs="?", type=Path, default=None, help="with report: the results.parquet")
    ca.add_argument("--out", type=Path, default=None, help="results folder (default runs/campaigns/<name>)")
    ca.add_argument("--scheduler", default=None, help="an existing Dask scheduler, tcp://HOST:PORT (default: a local cluster)")
    ca.add_argument("--workers", type=arguments.whole_number, default=None, help="local cluster size (default: one per core)")
    ca.add_argument("--fmus", type=Path, default=arguments.DEFAULT_FMU_DIR, help="FMU folder (default: fmus)")
    ca.add_argument("--spec", type=Path, default=None, help="with report: the spec, for the rerun commands")
    ca.add_argument("--x", default=None, help="with report: the varied parameter on the maps' x axis")
    ca.add_argument("--y", default=None, help="with report: the varied parameter on the maps' y axis")
    ca.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if args.what == "report":
        from ..campaign.report import report

        if args.results is None:
            raise UserError("campaign report: name the results file (e.g. runs/campaigns/NAME/results.parquet)")
        print(f"report: {report(args.results, args.spec, args.x, args.y)}")
        return 0
    from ..campaign.runner import run as run_campaign

    if args.results is not None:
        raise UserError(f"campaign: unexpected argument {args.results} (to report: tiltload campaign report RESULTS)")
    results, counts = run_campaign(Path(args.what), args.out, args.scheduler, args.workers, args.fmus)
    print(f"{counts['total']} runs: {counts['skipped']} were done, {counts['ran']} ran, {counts['failed']} failed")
    print(f"results: {results}")
    return 0

"""`tiltload campaign-report RESULTS`: a campaign's results summarized in report.html and report.md, with its figures
beside them."""

from __future__ import annotations

import argparse
from pathlib import Path


def add_parser(sub) -> None:
    cr = sub.add_parser("campaign-report", help="summarize a campaign's results: report.html and report.md, distributions, "
                                                "maps, the worst runs with the commands that rerun them")
    add_report_arguments(cr)
    cr.set_defaults(func=run)


def add_report_arguments(p: argparse.ArgumentParser, results_help: str | None = None) -> None:
    p.add_argument("results", type=Path,
                   help=results_help or "the campaign's results file, e.g. runs/campaigns/NAME/results.parquet "
                                        "(report.html, report.md and their figures are written beside it)")
    p.add_argument("--spec", type=Path, default=None,
                   help="the campaign's spec, for the rerun commands (default: the copy beside the results)")
    p.add_argument("--x", default=None, help="the varied parameter on the maps' x axis (default: the first varied)")
    p.add_argument("--y", default=None, help="the varied parameter on the maps' y axis (default: the second varied)")


def run(args: argparse.Namespace) -> int:
    from ..campaign.report import report, written

    print(written(report(args.results, args.spec, args.x, args.y)))
    return 0

"""`tiltload campaign SPEC` runs a campaign on Dask; `tiltload campaign report RESULTS` summarizes one."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .. import arguments
from ..errors import UserError

seconds = arguments.positive_time


def add_parser(sub) -> None:
    ca = sub.add_parser("campaign", help="run a campaign spec on Dask (TOML/YAML), or 'report RESULTS' to summarize one")
    ca.add_argument("what", help="the campaign spec, or 'report'")
    ca.add_argument("results", nargs="?", type=Path, default=None, help="with report: the results.parquet")
    ca.add_argument("--out", type=Path, default=None, help="results folder (default runs/campaigns/<name>)")
    ca.add_argument("--scheduler", default=None,
                    help="an existing Dask scheduler, tcp://HOST:PORT or tls://HOST:PORT (default: a local cluster on 127.0.0.1)")
    ca.add_argument("--workers", type=arguments.whole_number, default=None,
                    help="local cluster size (default: one per core); with --scheduler: wait for this many workers (default 1)")
    ca.add_argument("--connect-timeout", type=seconds, default=5.0, metavar="S",
                    help="s for the scheduler to answer (default 5)")
    ca.add_argument("--worker-timeout", type=seconds, default=30.0, metavar="S",
                    help="s to wait for workers, before the runs and whenever none is left (default 30)")
    ca.add_argument("--retries", type=arguments.integer(0, 100), default=2,
                    help="further tries of a run whose environment failed (a worker without the FMUs...), default 2")
    ca.add_argument("--retry-failed", action="store_true", help="run again the stored runs that failed")
    ca.add_argument("--verbose", action="store_true", help="Dask's log on the terminal too (it is always in <out>/campaign.log)")
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
    from ..campaign.errors import CampaignIncomplete

    try:
        results, counts = execute(args)
    except CampaignIncomplete as err:
        print(f"tiltload: error: {err}", file=sys.stderr)
        return 1
    print(summary(counts))
    print(f"results: {results}")
    return 0


def execute(args: argparse.Namespace) -> tuple[Path, dict]:
    """Run the campaign the arguments name: its results file and counts (tiltload.campaign returns them)."""
    from ..campaign.errors import ClusterError
    from ..campaign.runner import run as run_campaign

    if args.results is not None:
        raise UserError(f"campaign: unexpected argument {args.results} (to report: tiltload campaign report RESULTS)")
    try:
        return run_campaign(Path(args.what), args.out, args.fmus, scheduler=args.scheduler, workers=args.workers,
                            connect_timeout=args.connect_timeout, worker_timeout=args.worker_timeout, retries=args.retries,
                            retry_failed=args.retry_failed, verbose=args.verbose)
    except ClusterError as err:
        raise UserError(str(err)) from None


def summary(counts: dict) -> str:
    """What the results hold, then what this campaign did."""
    return (f"{counts['total']} runs: {counts['stored']} in the results, {counts['completed']} completed, "
            f"{counts['failed']} failed ({counts['diverged']} diverged); {counts['skipped']} were done before, "
            f"{counts['ran']} ran now")

"""`tiltload campaign SPEC` runs a campaign on Dask (`tiltload campaign-report RESULTS` summarizes one; the older
`tiltload campaign report RESULTS` still works, with a note naming the new form)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .. import arguments
from ..campaign.options import CAMPAIGN, HOUR
from ..errors import UserError
from ..loop.defaults import WORKER_TIMEOUT


def add_parser(sub) -> None:
    ca = sub.add_parser("campaign", help="run a campaign spec on Dask (TOML/YAML); tiltload campaign-report summarizes one")
    ca.add_argument("what", metavar="SPEC", help="the campaign spec to run, a TOML or YAML file (docs/campaigns.md)")
    ca.add_argument("results", nargs="?", type=Path, default=None, metavar="RESULTS",
                    help="only in the older form `campaign report RESULTS`, now `tiltload campaign-report RESULTS`")
    ca.add_argument("--out", type=arguments.folder, default=None, help="results folder (default runs/campaigns/<name>)")
    ca.add_argument("--scheduler", default=None,
                    help="an existing Dask scheduler, tcp://HOST:PORT or tls://HOST:PORT (default: a local cluster on 127.0.0.1)")
    ca.add_argument("--workers", **CAMPAIGN.option("workers"), default=None,
                    help="local cluster size (default: one per core); with --scheduler: wait for this many workers (default 1)")
    ca.add_argument("--connect-timeout", **CAMPAIGN.option("connect_timeout"), default=5.0, metavar="S",
                    help=f"s for the scheduler to answer (default 5; at most {HOUR:g})")
    ca.add_argument("--worker-timeout", **CAMPAIGN.option("worker_timeout"), default=WORKER_TIMEOUT, metavar="S",
                    help=f"s to wait for workers, before the runs and whenever none is left (default 30; at most "
                         f"{arguments.DAY:g})")
    ca.add_argument("--retries", **CAMPAIGN.option("retries"), default=2,
                    help="further tries of a run whose environment failed (a worker without the FMUs...), default 2")
    ca.add_argument("--retry-failed", action="store_true", help="run again the stored runs that failed")
    ca.add_argument("--verbose", action="store_true", help="Dask's log on the terminal too (it is always in <out>/campaign.log)")
    ca.add_argument("--fmus", type=arguments.folder, default=arguments.DEFAULT_FMU_DIR, help="FMU folder (default: fmus)")
    ca.add_argument("--allow-failures", action="store_true",
                    help="exit 0 even when a run failed or a requirement FAILed (default: exit 1 then, docs/exit_codes.md)")
    for name in ("--spec", "--x", "--y"):  # the older report form's options, hidden: campaign-report lists them
        ca.add_argument(name, type=Path if name == "--spec" else str, default=None, help=argparse.SUPPRESS)
    ca.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if args.what == "report":  # the older form: still works, and says what replaced it
        from .campaign_report import run as report

        if args.results is None:
            raise UserError("campaign-report: name the results file (tiltload campaign-report "
                            "runs/campaigns/NAME/results.parquet)")
        from ..campaign.report import ReportError

        note = "`tiltload campaign report RESULTS` is now `tiltload campaign-report RESULTS`"
        try:
            code = report(args)
        except ReportError as err:  # still one line: the error, and the new form
            raise ReportError(f"{err} (note: {note})") from None
        print(f"note: {note}", file=sys.stderr)
        return code
    from ..batch.errors import CampaignIncomplete

    if args.spec is not None or args.x is not None or args.y is not None:
        raise UserError("campaign: --spec, --x and --y are options of tiltload campaign-report RESULTS")
    try:
        results, counts = execute(args)
    except CampaignIncomplete as err:
        print(f"tiltload: error: {err}", file=sys.stderr)
        return 1
    from ..case.verdict_counts import counts_of_results

    tallies = counts_of_results(results)
    print(summary(counts))
    for t in tallies:  # the counts report.md, report.html and tl.campaign's result show
        print(t.line())
    print(f"results: {results}")
    failing = failures(counts, tallies)
    if failing and not args.allow_failures:
        print(f"tiltload: campaign: {failing} (exit 1; --allow-failures exits 0)", file=sys.stderr)
        return 1
    return 0


def failures(counts: dict, tallies: list) -> str:
    """What in the results fails the campaign as a test: runs that failed, requirements' FAILs ("" for none)."""
    said = [f"{counts['failed']} run(s) failed"] if counts.get("failed") else []
    return "; ".join(said + [f"requirement {t.name} FAILed in {t.counts['FAIL']} run(s)" for t in tallies if t.counts["FAIL"]])


def execute(args: argparse.Namespace) -> tuple[Path, dict]:
    """Run the campaign the arguments name (the API's core): its results file and counts."""
    from ..api.campaigns import CampaignOptions, run_campaign

    if args.results is not None:
        raise UserError(f"campaign: unexpected argument {args.results} (to report: tiltload campaign-report RESULTS)")
    options = CampaignOptions(out=args.out, scheduler=args.scheduler, workers=args.workers, connect_timeout=args.connect_timeout,
                              worker_timeout=args.worker_timeout, retries=args.retries, retry_failed=args.retry_failed,
                              verbose=args.verbose, fmus=args.fmus)
    return run_campaign(Path(args.what), options)


def summary(counts: dict) -> str:
    """What the results hold, then what this campaign did."""
    return (f"{counts['total']} runs: {counts['stored']} in the results, {counts['completed']} completed, "
            f"{counts['failed']} failed ({counts['diverged']} diverged); {counts['skipped']} were done before, "
            f"{counts['ran']} ran now")

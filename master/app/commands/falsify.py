"""`tiltload falsify SPEC`: search the spec's space for a case that violates its requirements (docs/falsification.md)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .. import arguments
from ..falsify.options import FALSIFY


def add_parser(sub) -> None:
    f = sub.add_parser("falsify", help="search wind, faults and parameters for a case that breaks a requirement (STL)")
    f.add_argument("spec", type=Path, help="the falsification spec (TOML/YAML): docs/falsification.md")
    f.add_argument("--out", type=arguments.folder, default=None, help="results folder (default runs/falsify/<name>-<optimizer>-<seed>)")
    f.add_argument("--optimizer", **FALSIFY.option("optimizer"), default=None, help="instead of the spec's")
    f.add_argument("--seed", **FALSIFY.option("seed"), default=None, help="the optimizer's seed, instead of the spec's")
    f.add_argument("--simulations", **FALSIFY.option("simulations"), default=None, help="budget, instead of the spec's")
    f.add_argument("--seconds", **FALSIFY.option("seconds"), default=None, help="wall-time budget, instead of the spec's")
    f.add_argument("--scheduler", default=None, help="an existing Dask scheduler (default: a local cluster on 127.0.0.1)")
    f.add_argument("--workers", **FALSIFY.option("workers"), default=None, help="local cluster size (default: one per core)")
    f.add_argument("--fmus", type=arguments.folder, default=arguments.DEFAULT_FMU_DIR, help="FMU folder (default: fmus)")
    f.add_argument("--no-early-stop", action="store_true",
                   help="run every evaluation to the stop time (default: stop at the first violation that cannot change)")
    f.add_argument("--branch", **FALSIFY.option("branch"), default="auto",
                   help="branch evaluations from a snapshot where the searched inputs act late (auto: if measured faster)")
    f.add_argument("--neighbourhood", action="store_true",
                   help="then run a grid around the best case: how wide the failure region is (docs/falsification.md)")
    f.add_argument("--neighbourhood-fraction", **FALSIFY.option("neighbourhood_fraction"), default=0.1,
                   help="the grid's half-width, a fraction of each dimension's range (default 0.1)")
    f.add_argument("--neighbourhood-points", **FALSIFY.option("neighbourhood_points"), default=None,
                   help="grid values per dimension (default 5, 3 from four dimensions on)")
    f.set_defaults(func=run)


def options_of(args: argparse.Namespace):
    """The FalsifyOptions of the command line (the object tiltload.falsify builds from its keywords)."""
    from dataclasses import fields

    from ..api.falsifying import FalsifyOptions

    return FalsifyOptions(**{f.name: getattr(args, f.name) for f in fields(FalsifyOptions)})


def run(args: argparse.Namespace) -> int:
    from ..api.falsifying import run_falsification
    from ..batch.errors import CampaignIncomplete

    try:
        _, outcome, out = run_falsification(args.spec, options_of(args))
    except CampaignIncomplete as err:
        print(f"tiltload: error: {err}", file=sys.stderr)
        return 1
    print((out / "summary.txt").read_text(), end="")
    print(f"results: {out / 'falsification.parquet'}; figure: {out / 'best_robustness.png'}; report: {out / 'report.html'}")
    if args.neighbourhood and (out / "neighbourhood" / "neighbourhood.txt").is_file():
        print((out / "neighbourhood" / "neighbourhood.txt").read_text(), end="")
    failed = [r for r in outcome.rows if r.get("error")]
    if failed and len(failed) == len(outcome.rows):  # nothing was judged: no search happened, say why (the runs' words)
        print(f"tiltload: error: every simulation ended in an error, none was judged; the first: {failed[0]['error']}",
              file=sys.stderr)
        return 1
    return 1 if outcome.falsified_at is not None else 0  # a counterexample is a failing test (docs/exit_codes.md)

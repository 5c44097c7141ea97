"""`tiltload compare RUN BASELINE`: a run's metrics against a baseline, for the same case; exit 0 same, 1 different."""

from __future__ import annotations

import argparse
from pathlib import Path

from .. import arguments


def add_parser(sub) -> None:
    cp = sub.add_parser("compare", help="compare a run's metrics with a baseline (a log or a metrics file) of the same case; "
                                        "exit 0 same, 1 different")
    cp.add_argument("run", type=Path)
    cp.add_argument("baseline", type=Path)
    cp.add_argument("--rtol", type=arguments.tolerance, default=None,
                    help="relative tolerance for every metric, in place of the baseline's own (default: the baseline "
                         "file's per-metric tolerances, else 1e-6)")
    cp.add_argument("--atol", type=arguments.tolerance, default=None,
                    help="absolute tolerance for every metric, in place of the baseline's own (default: the baseline "
                         "file's, else 1e-12)")
    cp.add_argument("--any-case", action="store_true",
                    help="compare the metrics even if the two are different cases (scenario, trajectory, controller, seed, "
                         "stop time, --set, faults, wind, ...); by default that is refused with one line saying what differs")
    cp.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..regression.compare import compare_files

    result = compare_files(args.run, args.baseline, args.rtol, args.atol, args.any_case)
    for note in result.notes:
        print(f"note: {note}")
    print(result.table())
    print("same within tolerance" if result.ok else "DIFFERENT: at least one metric is out of tolerance")
    return 0 if result.ok else 1

"""`tiltload compare RUN BASELINE`: a run's metrics against a baseline, for the same case; exit 0 same, 1 different."""

from __future__ import annotations

import argparse
from pathlib import Path

from .. import arguments


def add_parser(sub) -> None:
    cp = sub.add_parser("compare", help="compare a run's metrics with a baseline (a log or a metrics file) of the same case; "
                                        "exit 0 same, 1 different")
    cp.add_argument("run", type=Path, help="the run: its MCAP log (runs/NAME.mcap) or a metrics file (JSON)")
    cp.add_argument("baseline", type=Path,
                    help="what to compare with: another run's MCAP log or a metrics file (JSON, with per-metric tolerances)")
    cp.add_argument("--rtol", type=arguments.tolerance, default=None,
                    help="relative tolerance for every metric, in place of the baseline's own (default: the baseline "
                         "file's per-metric tolerances, else 1e-6)")
    cp.add_argument("--atol", type=arguments.tolerance, default=None,
                    help="absolute tolerance for every metric, in place of the baseline's own (default: the baseline "
                         "file's, else 1e-12)")
    cp.add_argument("--requirements", type=Path, default=None, metavar="REQS",
                    help="also judge both logs against these requirements: a verdict that changes is a difference, "
                         "robustness is compared with the tolerances")
    cp.add_argument("--any-case", action="store_true",
                    help="compare the metrics even if the two are different cases (scenario, trajectory, controller, seed, "
                         "stop time, --set, faults, wind, ...); by default that is refused with one line saying what differs")
    cp.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..regression.compare import compare_files

    result = compare_files(args.run, args.baseline, args.rtol, args.atol, args.any_case)
    if result.changed_line():
        print(result.changed_line())
    for note in result.notes:
        print(f"note: {note}")
    print(result.table())
    ok = result.ok
    if args.requirements is not None:
        from ...engine.requirement_check import check_log
        from ...engine.requirements import load
        from ..errors import UserError
        from ..regression import compare as cmp

        if args.baseline.suffix == ".json" or args.run.suffix == ".json":
            raise UserError("--requirements compares two logs' verdicts: give the baseline as an MCAP log")
        reqs = load(args.requirements)
        rtol = args.rtol if args.rtol is not None else cmp.DEFAULT_RTOL
        atol = args.atol if args.atol is not None else cmp.DEFAULT_ATOL
        same, vrows = cmp.compare_verdicts(check_log(args.run, reqs, missing="inconclusive"),
                                           check_log(args.baseline, reqs, missing="inconclusive"), rtol, atol)
        print(cmp.format_verdict_rows(vrows))
        ok &= same
    print("same within tolerance" if ok else "DIFFERENT: at least one metric or verdict is out of tolerance")
    return 0 if ok else 1

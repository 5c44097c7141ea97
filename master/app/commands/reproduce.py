"""`tiltload reproduce`: the twelve cases of ch. 5 in parallel: tables against the thesis, figures, baselines."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .. import arguments


def add_parser(sub) -> None:
    rp = sub.add_parser("reproduce", help="the twelve cases of ch. 5 in parallel: tables vs the thesis, figures, baselines")
    rp.add_argument("--fmus", type=arguments.folder, default=arguments.DEFAULT_FMU_DIR)
    rp.add_argument("--out", type=arguments.folder, default=Path("runs/reproduce"),
                    help="logs, figures, results.md (default runs/reproduce)")
    rp.add_argument("--docs", type=arguments.output_file, default=None, help="also write this results document (e.g. docs/results.md)")
    rp.add_argument("--baselines", type=arguments.folder, default=Path("baselines"), help="baseline folder (default baselines)")
    rp.add_argument("--write-baselines", action="store_true", help="store the metrics as the new baselines")
    rp.add_argument("--check", action="store_true", help="compare every case with its baseline; exit 1 on a difference")
    rp.add_argument("--workers", type=arguments.whole_number, default=None, help="processes (default: one per core)")
    rp.add_argument("--fmi", type=int, choices=(2, 3), default=2, help="run the FMI 2.0 FMUs (default) or the FMI 3.0 ones "
                    "(FMUS/fmi3/): the metrics are the same, bit for bit (docs/fmi3.md)")
    rp.add_argument("--clocks", action="store_true", help="with --fmi 3: the sensors and the controller with clocks")
    rp.add_argument("--requirements", type=Path, action="append", default=[], metavar="REQS",
                    help="judge every case's log against these requirements (e.g. docs/requirements/thesis.yaml; "
                         "repeatable): a table of verdicts, case by requirement")
    rp.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ...engine.requirement.files import load
    from ..errors import UserError
    from ..loop.fmus import build_all, fmu_folder
    from ..regression.reproduce import CASES, case_name, main

    if args.clocks and args.fmi != 3:
        raise UserError("--clocks: clocks are FMI 3.0's; add --fmi 3")
    reqs = [r for path in args.requirements for r in load(path)]  # a bad file is refused before anything runs
    if args.docs is not None:  # before the runs: a place the document cannot go, or one of the requirement files
        from ..output_folder import writable_file

        writable_file(args.docs, "--docs", [("a requirement file", p) for p in args.requirements])
    folder = fmu_folder(args.fmus, args.fmi)
    build_all(folder, progress=lambda m: print(m, file=sys.stderr), fmi_version=args.fmi, clocked=args.clocks)
    code = main(folder, args.out, args.docs, args.baselines, args.write_baselines, args.check, args.workers, args.fmi,
                args.clocks)
    if reqs:
        failed = verdict_table(reqs, [args.out / f"{case_name(*c)}.mcap" for c in CASES])
        code = code or (1 if failed else 0)
    return code


def verdict_table(reqs, logs: list[Path]) -> bool:
    """Each case's verdicts (P, F, I, 0 for ZERO, - for no log), one row a requirement; True if any FAIL."""
    from ...engine.requirement.check import check_log

    verdicts = {}
    for log in logs:
        if log.is_file():
            verdicts[log.stem] = {r.name: r for r in check_log(log, reqs, missing="inconclusive")}
    width = max(len(r.name) for r in reqs)
    print("requirements (P pass, F fail, I inconclusive, 0 zero robustness), by case:")
    print(f"  {'':<{width}}  " + " ".join(f"{log.stem.replace('_traj', ' ')[:12]:>12}" for log in logs))
    mark = {"PASS": "P", "FAIL": "F", "INCONCLUSIVE": "I", "ZERO": "0"}
    for r in reqs:
        cells = [mark[verdicts[log.stem][r.name].verdict] if log.stem in verdicts else "-" for log in logs]
        print(f"  {r.name:<{width}}  " + " ".join(f"{c:>12}" for c in cells))
    fails = [(case, res) for case, rs in verdicts.items() for res in rs.values() if res.verdict == "FAIL"]
    for case, res in fails:
        print(f"  FAIL {case}: {res.name}, robustness {res.robustness if res.robustness is not None else res.bounds[1]:.4g}, "
              f"first at t = {res.first_violation:.3f} s")
    return bool(fails)

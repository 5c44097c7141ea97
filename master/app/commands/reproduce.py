"""`tiltload reproduce`: the twelve cases of ch. 5 in parallel: tables against the thesis, figures, baselines."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .. import arguments


def add_parser(sub) -> None:
    rp = sub.add_parser("reproduce", help="the twelve cases of ch. 5 in parallel: tables vs the thesis, figures, baselines")
    rp.add_argument("--fmus", type=Path, default=arguments.DEFAULT_FMU_DIR)
    rp.add_argument("--out", type=Path, default=Path("runs/reproduce"), help="logs, figures, results.md (default runs/reproduce)")
    rp.add_argument("--docs", type=Path, default=None, help="also write this results document (e.g. docs/results.md)")
    rp.add_argument("--baselines", type=Path, default=Path("baselines"), help="baseline folder (default baselines)")
    rp.add_argument("--write-baselines", action="store_true", help="store the metrics as the new baselines")
    rp.add_argument("--check", action="store_true", help="compare every case with its baseline; exit 1 on a difference")
    rp.add_argument("--workers", type=arguments.whole_number, default=None, help="processes (default: one per core)")
    rp.add_argument("--fmi", type=int, choices=(2, 3), default=2, help="run the FMI 2.0 FMUs (default) or the FMI 3.0 ones "
                    "(FMUS/fmi3/): the metrics are the same, bit for bit (docs/fmi3.md)")
    rp.add_argument("--clocks", action="store_true", help="with --fmi 3: the sensors and the controller with clocks")
    rp.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..errors import UserError
    from ..fmus import build_all, fmu_folder
    from ..regression.reproduce import main

    if args.clocks and args.fmi != 3:
        raise UserError("--clocks: clocks are FMI 3.0's; add --fmi 3")
    folder = fmu_folder(args.fmus, args.fmi)
    build_all(folder, progress=lambda m: print(m, file=sys.stderr), fmi_version=args.fmi, clocked=args.clocks)
    return main(folder, args.out, args.docs, args.baselines, args.write_baselines, args.check, args.workers, args.fmi,
                args.clocks)

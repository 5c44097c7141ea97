"""`tiltload b2b`: back-to-back runs of a case list, a reference and a candidate compared signal by signal in tolerance
tubes; exit 0 when every signal of every case stays in its tube, 1 when one leaves it."""

from __future__ import annotations

import argparse
from pathlib import Path

from .. import arguments
from ..loop.defaults import FMU_DIR


def add_parser(sub) -> None:
    bp = sub.add_parser("b2b", help="run a case list with a reference and a candidate (controllers, FMU builds, parameters) "
                                    "and compare them signal by signal in tolerance tubes; exit 0 same, 1 different")
    bp.add_argument("--cases", default="reproduction", metavar="LIST",
                    help="'reproduction' (the twelve cases of ch. 5) or a case list file (TOML, YAML, JSON: "
                         "cases = [{scenario, trajectory, controller, seed, stop_time}]); default: reproduction")
    for side in ("reference", "candidate"):
        bp.add_argument(f"--{side}-fmus", type=arguments.folder, default=FMU_DIR, metavar="DIR",
                        help=f"the {side}'s FMU folder (default: fmus)")
        bp.add_argument(f"--{side}-controller", type=arguments.controller, default=None, metavar="C",
                        help=f"the {side}'s controller: dlqr, mixed, a controller FMU or a class's .py file (wrapped as run "
                             "wraps it) (default: the case's)")
        bp.add_argument(f"--{side}-set", type=arguments.assignment, action="append", default=[], metavar="INSTANCE.NAME=VALUE",
                        help=f"set a parameter on the {side}'s side only (repeatable)")
        bp.add_argument(f"--{side}-stage", choices=("sil", "mil", "pil"), default="sil",
                        help=f"the {side}'s controller as sil (its FMU in this process, the default), mil (the thesis's "
                             "controller as its numpy reference, in Python) or pil (the FMU's aarch64 binary on tl_serve "
                             "under qemu-user); docs/mil_sil_pil.md")
    bp.add_argument("--signals", type=_names, default=None, metavar="LIST",
                    help="signals compared, instance.variable, comma-separated (default: plant x, y, z, psi and the four "
                         "controller outputs)")
    bp.add_argument("--tolerances", type=Path, default=None, metavar="FILE",
                    help="tolerances per signal (docs/back_to_back.md; default abs 1e-12, rel 1e-6)")
    for flag in ("abs", "rel", "lead", "lag"):
        bp.add_argument(f"--{flag}", type=arguments.tolerance, default=None, help=f"{flag} tolerance for every signal")
    bp.add_argument("--stop-time", type=arguments.run_time, default=None,
                    help="simulated seconds of every case (default: each case's own, its trajectory's duration)")
    bp.add_argument("--out", type=arguments.folder, default=Path("runs/b2b"), help="folder of the logs and figures (default: runs/b2b)")
    bp.add_argument("--figures", action="store_true", help="a figure of each signal outside its tube, into OUT")
    bp.set_defaults(func=run)


def _names(text: str) -> list[str]:
    names = [n.strip() for n in text.split(",") if n.strip()]
    if not names:
        raise argparse.ArgumentTypeError("name at least one signal (instance.variable)")
    return names


def run(args: argparse.Namespace) -> int:
    from ..api.back_to_back import B2BSide, b2b, case_list
    from ..regression.signal_compare import check_names

    signals = check_names(args.signals, "--signals") if args.signals else None
    sides = [B2BSide(getattr(args, f"{s}_fmus"), getattr(args, f"{s}_controller"), tuple(getattr(args, f"{s}_set")),
                     getattr(args, f"{s}_stage")) for s in ("reference", "candidate")]
    from ..output_folder import writable_folder

    cases = case_list(args.cases)
    writable_folder(args.out, "--out", min_free=0)  # before anything is said or run: a read-only place is one line
    print(f"back to back: {len(cases)} cases, each run as the reference ({sides[0].label}) and as the candidate "
          f"({sides[1].label}) (logs in {args.out}/)", flush=True)
    result = b2b(cases, reference=sides[0], candidate=sides[1], signals=signals, tolerances=args.tolerances,
                 **{f: getattr(args, f) for f in ("abs", "rel", "lead", "lag")}, stop_time=args.stop_time, out=args.out,
                 progress=lambda line: print(line, flush=True))
    print(("what changed: " + "; ".join(result.changes)) if result.changes else
          "what changed: nothing in the FMUs or their parameters (the same run twice?)")
    print(result.table())
    if args.figures:
        from ..regression.tube_plot import tube_figures

        for r in result.results:
            for path in tube_figures(r.rows, args.out, r.name, r.name):
                print(f"figure: {path}")
    print("same within tolerance" if result.ok else "DIFFERENT: at least one signal leaves its tolerance tube")
    return 0 if result.ok else 1

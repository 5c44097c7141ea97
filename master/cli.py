"""The `tiltload` command: build the FMUs, run the main job."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import numpy as np

DEFAULT_FMU_DIR = Path("fmus")


class UserError(Exception):
    """A problem the user can fix; reported as one line, exit code 2."""


def cmd_build(args: argparse.Namespace) -> int:
    from .build_all import build_all

    for result in build_all(args.out, force=args.force):
        state = "built" if result.rebuilt else "up to date"
        print(f"{result.path}: {state} ({result.seconds:.1f} s)")
    return 0


def cmd_design(args: argparse.Namespace) -> int:
    from ..controller_fmu import artifact
    from ..controller_fmu.design import design
    from ..controller_fmu.error_dynamics import DesignError

    try:
        d = design(args.controller, args.Tc, use_cache=not args.fresh)
    except DesignError as err:
        raise UserError(str(err)) from None
    path = artifact.save(d, args.out / f"{d.kind}.json")
    r = d.report
    print(f"{d.kind}: ||K||_2 = {r['gain_norm']:.4g}, closed-loop spectral radius = {r['spectral_radius']:.6f} "
          f"(slowest continuous-time decay {np.log(r['spectral_radius']) / d.Tc:.3f} /s), {r['seconds']:.1f} s")
    if "riccati_residual" in r:
        print(f"  Riccati residual {r['riccati_residual']:.1e}")
    else:
        h2 = f", H2 bound {r['h2_bound']:.4g} (measured {r['h2_norm']:.4g})" if r["h2_bound"] else ""
        print(f"  H-infinity bound {r['gamma_bound']:.4g} (measured {r['hinf_norm']:.4g}){h2}; "
              f"poles in Re > {r['regions']['eps']} and |z| < {r['regions']['varpi']}; solver {r['solver_status']}")
    print(f"saved {path}")
    return 0


def cmd_run(args: argparse.Namespace) -> int:
    from . import hover

    return hover.main(args)


def _positive_time(text: str) -> float:
    value = float(text)
    if not (value > 0 and value < float("inf")):
        raise argparse.ArgumentTypeError(f"must be a positive finite time in s, got {text}")
    return value


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="tiltload", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    b = sub.add_parser("build", help="build the FMUs into fmus/ (only what is missing or stale)")
    b.add_argument("--out", type=Path, default=DEFAULT_FMU_DIR, help="output folder (default: fmus)")
    b.add_argument("--force", action="store_true", help="rebuild even if up to date")
    b.set_defaults(func=cmd_build)
    d = sub.add_parser("design", help="design a controller of the thesis (ch. 3) and save it as an artifact")
    d.add_argument("--controller", default="dlqr", help="dlqr (default), hinf or mixed")
    d.add_argument("--Tc", type=_positive_time, default=0.012, help="controller period in s (default 0.012)")
    d.add_argument("--out", type=Path, default=Path("designs"), help="output folder (default: designs)")
    d.add_argument("--fresh", action="store_true", help="synthesize again even if an identical design is cached")
    d.set_defaults(func=cmd_design)
    r = sub.add_parser("run", help="main job: build if needed, then run the plant FMU's default experiment")
    r.add_argument("--fmus", type=Path, default=DEFAULT_FMU_DIR, help="FMU folder (default: fmus)")
    r.add_argument("--stop-time", type=_positive_time, default=None, help="stop time in s (default: the FMU's, 2 s)")
    r.add_argument("--out", type=Path, default=Path("runs"), help="where the result CSV and plot go")
    r.set_defaults(func=cmd_run)
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except UserError as err:
        print(f"tiltload: error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("tiltload: interrupted", file=sys.stderr)
        return 130
    except Exception as err:  # one line for the user; TILTLOAD_DEBUG=1 shows the traceback
        if os.environ.get("TILTLOAD_DEBUG"):
            raise
        print(f"tiltload: error: {type(err).__name__}: {err}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())

"""`tiltload formation`: the formation of three UAVs (Appendix B), seven FMUs, logged and plotted."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .. import arguments


def add_parser(sub) -> None:
    fo = sub.add_parser("formation", help="the formation of three UAVs (Appendix B): 7 FMUs, log, error norms, paths")
    fo.add_argument("--controller", choices=("both", "backstepping", "tsid"), default="both",
                    help="the formation controller: backstepping (B.15), tsid (B.16) or both (default, one figure)")
    fo.add_argument("--disturbances", action="store_true",
                    help="constant acceleration disturbances and external forces from t = 10 s (docs/formation.md)")
    fo.add_argument("--stop-time", type=arguments.positive_time, default=60.0, help="s (default 60)")
    fo.add_argument("--fmus", type=arguments.folder, default=arguments.DEFAULT_FMU_DIR, help="FMU folder (default: fmus)")
    fo.add_argument("--out", type=arguments.folder, default=Path("runs/formation"), help="logs and figures (default runs/formation)")
    fo.add_argument("--no-plots", action="store_true", help="skip the PNG figures")
    fo.add_argument("--quiet", action="store_true", help="no progress bar")
    fo.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..errors import run_failed
    from ..formation import runner as formation
    from ..loop.fmus import build_formation

    build_formation(args.fmus, progress=lambda m: print(m, file=sys.stderr))
    controllers = ("backstepping", "tsid") if args.controller == "both" else (args.controller,)
    runs = []
    for controller in controllers:
        print(f"formation, {controller}{' with disturbances' if args.disturbances else ''}: {args.stop_time:g} s, 7 FMUs")
        r = formation.run(args.fmus, args.out, controller, args.disturbances, args.stop_time, progress=not args.quiet)
        if r.result.error:
            return run_failed(r.result.error, r.result.signal, r.log, r.result.sim_time)
        print(f"  {r.result.sim_time:.2f} s simulated in {r.result.wall:.1f} s; error norm: max {r.error.max():.4g}, "
              f"over the last 5 s at most {r.settled():.3g}; log: {r.log}")
        runs.append(r)
    if not args.no_plots:
        print(f"plots: {', '.join(str(f) for f in formation.plot(runs, args.out, args.disturbances))}")
    return 0

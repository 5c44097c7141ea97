"""`tiltload plot LOG`: the thesis's kinds of figures from a run's MCAP log."""

from __future__ import annotations

import argparse
from pathlib import Path

from .. import arguments
from ..errors import UserError


def add_parser(sub) -> None:
    pl = sub.add_parser("plot", help="draw the thesis's kinds of figures from a run's MCAP log")
    pl.add_argument("log", type=Path, help="the run's MCAP log, e.g. runs/NAME.mcap (written by tiltload run)")
    pl.add_argument("--out", type=arguments.folder, default=None, help="folder for the PNGs (default: next to the log)")
    pl.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    import sys

    from ...engine.user_files import open_binary
    from ..views.plot import plot_intact

    with open_binary(args.log, "log") as f:
        if f.read(8) != b"\x89MCAP0\r\n":
            raise UserError(f"{args.log} is not an MCAP log (no MCAP magic at its start)")
    try:
        files, state = plot_intact(args.log, args.out)
    except ValueError as err:  # a log of another system: no /plant channel (or nothing intact)
        raise UserError(str(err)) from None
    for f in files:
        print(f)
    if state.damage is not None:  # the figures are of the intact part only: say so, and do not exit 0
        print(f"tiltload: error: {state.describe(args.log)}; the figures show that part only", file=sys.stderr)
        return 1
    if state.torn:
        print(f"note: {state.describe(args.log)}; the figures show what it holds")
    return 0

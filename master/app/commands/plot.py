"""`tiltload plot LOG`: the thesis's kinds of figures from a run's MCAP log."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..errors import UserError


def add_parser(sub) -> None:
    pl = sub.add_parser("plot", help="draw the thesis's kinds of figures from a run's MCAP log")
    pl.add_argument("log", type=Path)
    pl.add_argument("--out", type=Path, default=None, help="folder for the PNGs (default: next to the log)")
    pl.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ...engine.log_reader import is_truncated
    from ..plot import plot_run

    if not args.log.is_file():
        raise UserError(f"{args.log} does not exist")
    with open(args.log, "rb") as f:
        if f.read(8) != b"\x89MCAP0\r\n":
            raise UserError(f"{args.log} is not an MCAP log (no MCAP magic at its start)")
    if is_truncated(args.log):
        print(f"note: {args.log} is truncated (no footer: a killed run); plotting what it holds")
    try:
        files = plot_run(args.log, args.out)
    except ValueError as err:  # a log of another system: no /plant channel
        raise UserError(str(err)) from None
    for f in files:
        print(f)
    return 0

"""`tiltload layout`: the Foxglove layout for tiltload logs."""

from __future__ import annotations

import argparse
from pathlib import Path

from .. import arguments
from ..errors import UserError


def add_parser(sub) -> None:
    lo = sub.add_parser("layout", help="write the Foxglove layout for tiltload logs (3D replay, tracking, bounds, actuators)")
    lo.add_argument("out", type=arguments.output_file, nargs="?", default=Path("runs/foxglove_layout.json"),
                    help="the layout file to write (default: runs/foxglove_layout.json)")
    lo.add_argument("--formation", action="store_true", help="the layout for `tiltload formation` logs (three UAVs)")
    lo.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..output_folder import writable_file
    from ..views.foxglove_layout import write

    writable_file(args.out, "OUT")
    try:
        path = write(args.out, args.formation)
    except OSError as err:
        raise UserError(f"cannot write {args.out}: {err.strerror or err}") from None
    print(f"{path}: Foxglove layout (in Foxglove: open a run's .mcap, then Layouts -> Import from file)")
    return 0

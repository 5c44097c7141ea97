"""`tiltload wrap`: your Python controller class as a controller FMU that follows the port contract."""

from __future__ import annotations

import argparse
from pathlib import Path


def add_parser(sub) -> None:
    w = sub.add_parser("wrap", help="package your Python controller class as a controller FMU (docs/ports.md)")
    w.add_argument("controller", type=Path, help="the .py file with the controller class")
    w.add_argument("--class", dest="cls", default=None, help="the class to wrap, if the file has several")
    w.add_argument("--out", type=Path, default=None, help="the FMU to write (default: next to the file, <name>.fmu)")
    w.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..wrap.wrap import wrap

    target = wrap(args.controller, args.out, args.cls)
    print(f"{target}: controller FMU (use it with: tiltload run --controller {target})")
    return 0

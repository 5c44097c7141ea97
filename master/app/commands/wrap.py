"""`tiltload wrap`: your Python controller class as a controller FMU that follows the port contract."""

from __future__ import annotations

import argparse
from pathlib import Path

from .. import arguments


def add_parser(sub) -> None:
    w = sub.add_parser("wrap", help="package your Python controller class as a controller FMU (docs/ports.md)")
    w.add_argument("controller", type=Path, help="the .py file with the controller class")
    w.add_argument("--class", dest="cls", default=None, help="the class to wrap, if the file has several")
    w.add_argument("--out", type=arguments.output_file, default=None, help="the FMU to write (default: next to the file, <name>.fmu)")
    w.add_argument("--native", action="store_true",
                   help="trace the class's step with CasADi and build a native C FMU (no Python needed to run it; Linux, "
                        "Windows, aarch64; docs/ports.md says what can be traced)")
    w.add_argument("--fmi", type=int, choices=(2, 3), default=2, help="with --native: the FMI version (default 2)")
    w.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..output_folder import writable_file

    if args.out is not None:  # before the class is run: a place the FMU cannot go, or the class's own file
        writable_file(args.out, "--out", [("the controller's source", args.controller)])
    if args.native:
        from ..wrap.native import wrap_native

        target = wrap_native(args.controller, args.out, args.cls, args.fmi)
        print(f"{target}: native controller FMU, traced from {args.controller.name} "
              f"(use it with: tiltload run --controller {target})")
        return 0
    if args.fmi != 2:
        from ..errors import UserError

        raise UserError("wrap --fmi 3 is for --native (a pythonfmu FMU is FMI 2.0)")
    from ..wrap.sandbox import wrap_python

    target = wrap_python(args.controller, args.out, args.cls)
    print(f"{target}: controller FMU (use it with: tiltload run --controller {target})")
    return 0

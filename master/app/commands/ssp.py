"""`tiltload ssp export`: the loop as an SSP 1.0 package that libcosim, Ecos and tiltload run."""

from __future__ import annotations

import argparse
from pathlib import Path

from .. import arguments
from ..errors import UserError


def add_parser(sub) -> None:
    x = sub.add_parser("ssp", help="export the loop as an SSP 1.0 package that libcosim, Ecos and tiltload run (docs/ports.md)")
    x.add_argument("action", choices=("export",), help="export: write the package")
    x.add_argument("out", type=Path, help="the package to write, e.g. loop.ssp")
    arguments.add_loop_options(x)
    x.add_argument("--schedule", choices=("jacobi", "ordered"), default="jacobi",
                   help="the master the package is for: jacobi (libcosim, Ecos; default) selects the designs made for the "
                        "2-tick loop delay it adds; ordered (tiltload) selects 0")
    x.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ....controller_fmu.design.cache import cache_root
    from ...engine import ssp
    from ..loop import select_loop_delay
    from ..options import loop_system, resolve_loop

    loop = loop_system(resolve_loop(args), cache_root() / "ssp")  # the one action, export (argparse checked it)
    system, stop = loop.system, loop.stop
    delay = select_loop_delay(system, args.schedule)
    try:
        path = ssp.export(system, args.out, stop, args.schedule)
    except OSError as err:
        raise UserError(f"cannot write {args.out}: {err.strerror or err}") from None
    print(f"{path}: SSP 1.0 package, {len(system.instances)} FMUs, {stop:g} s, prepared for a {args.schedule} master"
          + (f"; the controller's designs for a {delay}-tick loop delay" if delay is not None else ""))
    print(f"  run it: tiltload run --system {path}   (libcosim: CosimExecution.from_ssp_file; Ecos: init(parameter_set="
          f"'{ssp.PARAMETER_SET}'))")
    return 0

"""`tiltload ssp export`: the loop as an SSP 1.0 package that libcosim, Ecos and tiltload run; with FMI 3.0 FMUs
(--fmi 3, --clocks) an SSP 2.0 package (FMI 3.0 types and clocks) that tiltload runs."""

from __future__ import annotations

import argparse
from pathlib import Path

from .. import arguments
from ..errors import UserError


def add_parser(sub) -> None:
    x = sub.add_parser("ssp", help="export the loop as an SSP package: SSP 1.0 (libcosim, Ecos, tiltload; docs/ports.md), or "
                                   "SSP 2.0 with --fmi 3 (docs/fmi3.md)")
    x.add_argument("action", choices=("export",), help="export: write the package")
    x.add_argument("out", type=Path, help="the package to write, e.g. loop.ssp")
    arguments.add_loop_options(x)
    x.add_argument("--schedule", choices=("jacobi", "ordered"), default=None,
                   help="the master the package is for: jacobi (libcosim, Ecos; the default for SSP 1.0) selects the designs "
                        "made for the 2-tick loop delay it adds; ordered (tiltload; the default for SSP 2.0) selects 0")
    x.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    path, version2, schedule, delay, count, stop = export(args, args.out, args.schedule)
    print(f"{path}: SSP {'2.0' if version2 else '1.0'} package, {count} FMUs, {stop:g} s, prepared for a "
          f"{schedule} master" + (f"; the controller's designs for a {delay}-tick loop delay" if delay is not None else ""))
    from ...engine import ssp

    others = ("" if version2 else f"   (libcosim: CosimExecution.from_ssp_file; Ecos: init(parameter_set='{ssp.PARAMETER_SET}'))")
    print(f"  run it: tiltload run --system {path}{others}")
    return 0


def export(args: argparse.Namespace, out: Path, schedule: str | None = None):
    """The loop the options describe as an SSP package at out (SSP 2.0 when its FMUs are FMI 3.0): (path, SSP 2.0?,
    the schedule it is prepared for, the controller's loop delay in ticks or None, FMUs, stop time)."""
    from ....controller_fmu.design.cache import cache_root
    from ...engine import ssp, ssp2
    from ...engine.model_description import read_fmu
    from ..loop import select_loop_delay
    from ..options import loop_system, resolve_loop

    loop = loop_system(resolve_loop(args), cache_root() / "ssp")
    system, stop = loop.system, loop.stop
    version2 = ssp2.needs_ssp2({i.name: read_fmu(i.fmu, i.name) for i in system.instances})
    schedule = schedule or ("ordered" if version2 else "jacobi")
    delay = select_loop_delay(system, schedule)
    try:
        path = (ssp2 if version2 else ssp).export(system, out, stop, schedule)
    except OSError as err:
        raise UserError(f"cannot write {out}: {err.strerror or err}") from None
    return path, version2, schedule, delay, len(system.instances), stop

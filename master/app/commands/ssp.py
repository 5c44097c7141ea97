"""`tiltload ssp export`: the loop as an SSP 1.0 package that libcosim, Ecos and tiltload run; with FMI 3.0 FMUs
(--fmi 3, --clocks) an SSP 2.0 package (FMI 3.0 types and clocks) that tiltload runs."""

from __future__ import annotations

import argparse

from .. import arguments


def add_parser(sub) -> None:
    x = sub.add_parser("ssp", help="export the loop as an SSP package: SSP 1.0 (libcosim, Ecos, tiltload; docs/ports.md), or "
                                   "SSP 2.0 with --fmi 3 (docs/fmi3.md)")
    x.add_argument("action", choices=("export",), help="export: write the package")
    x.add_argument("out", type=arguments.output_file, help="the package to write, e.g. loop.ssp")
    arguments.add_loop_options(x)
    x.add_argument("--schedule", choices=("jacobi", "ordered"), default=None,
                   help="the master the package is for: jacobi (libcosim, Ecos; the default for SSP 1.0) selects the designs "
                        "made for the 2-tick loop delay it adds; ordered (tiltload; the default for SSP 2.0) selects 0")
    x.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..export.ssp import export
    from ..output_folder import writable_file

    writable_file(args.out, "OUT")  # before the FMUs are built: a place the package cannot go is one line
    path, version2, schedule, delay, count, stop = export(args, args.out, args.schedule)
    article = "an" if schedule[:1] in "aeiou" else "a"
    print(f"{path}: SSP {'2.0' if version2 else '1.0'} package, {count} FMUs, {stop:g} s, prepared for {article} "
          f"{schedule} master" + (f"; the controller's designs for a {delay}-tick loop delay" if delay is not None else ""))
    from ...engine.ssp.schema import PARAMETER_SET

    others = ("" if version2 else f"   (libcosim: CosimExecution.from_ssp_file; Ecos: init(parameter_set='{PARAMETER_SET}'))")
    print(f"  run it: tiltload run --system {path}{others}")
    return 0

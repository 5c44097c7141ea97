"""`tiltload bundle OUT.zip`: every FMU for the three platforms, as FMI 2.0 and 3.0, the SSP packages and the port
contract in one archive, for users of other FMI tools (master/app/bundle.py)."""

from __future__ import annotations

import argparse

from .. import arguments


def add_parser(sub) -> None:
    b = sub.add_parser("bundle", help="write every FMU (FMI 2.0 and 3.0, Linux, Windows, aarch64 binaries), the SSP "
                                      "packages and the port contract into one zip, for other FMI tools")
    b.add_argument("out", type=arguments.output_file, help="the archive to write, e.g. tiltload-fmus.zip (it must not exist)")
    b.add_argument("--fmus", type=arguments.folder, default=arguments.DEFAULT_FMU_DIR,
                   help="the FMU folder the builds use and update (default: fmus; FMI 3.0 in fmus/fmi3)")
    b.add_argument("--force", action="store_true", help="rebuild every FMU even if up to date")
    b.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    import sys

    from ..bundle import write

    contents = write(args.out, args.fmus, args.force, progress=lambda m: print(m, file=sys.stderr))
    fmus = sum(m.endswith(".fmu") for m in contents)
    packages = sum(m.endswith(".ssp") for m in contents)
    print(f"{args.out}: {fmus} FMUs (FMI 2.0 and 3.0, binaries for linux64, win64, aarch64-linux), {packages} SSP "
          f"packages, PORTS.txt, README.txt ({args.out.stat().st_size / 1e6:.1f} MB)")
    return 0

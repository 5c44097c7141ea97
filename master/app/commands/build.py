"""`tiltload build`: every FMU into fmus/ (only what is missing or stale), with a binary per platform; `--fmi 3`: the
FMI 3.0 set into fmus/fmi3/ (the same platforms, under FMI 3.0's platform tuples)."""

from __future__ import annotations

import argparse
import sys

from .. import arguments
from ..arguments import DEFAULT_FMU_DIR


def platform_list(text: str) -> list[str]:
    """--platforms linux64,win64: known names only (a missing compiler is checked when building)."""
    from ....native_fmu.compile import BuildError, toolchain

    names = [n.strip() for n in text.split(",") if n.strip()]
    if not names:
        raise argparse.ArgumentTypeError("must name at least one platform, e.g. linux64,win64")
    try:
        return [toolchain(n).folder for n in names]
    except BuildError as err:
        raise argparse.ArgumentTypeError(str(err)) from None


def add_parser(sub) -> None:
    b = sub.add_parser("build", help="build the FMUs into fmus/ (only what is missing or stale)")
    b.add_argument("--out", type=arguments.folder, default=DEFAULT_FMU_DIR, help="output folder (default: fmus)")
    b.add_argument("--force", action="store_true", help="rebuild even if up to date")
    b.add_argument("--fmi", type=int, choices=(2, 3), default=2,
                   help="FMI version: 2 (default) into OUT/; 3: FMI 3.0 co-simulation into OUT/fmi3/, the plain FMUs and "
                        "the sensors' and controllers' variants with clocks (*Clocked.fmu; docs/fmi3.md)")
    b.add_argument("--platforms", type=platform_list, metavar="LIST",
                   help="comma-separated binaries to build: linux64, win64, aarch64-linux (default: each whose "
                        "compiler is installed; docs/platforms.md)")
    b.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ....native_fmu.compile import choose
    from ..loop.fmus import build_every

    toolchains, missing = choose(args.platforms)
    if missing:
        print(f"tiltload build: {missing}", file=sys.stderr)
    for result in build_every(args.out, args.fmi, toolchains, args.force):
        print(f"{result.path}: {'built' if result.rebuilt else 'up to date'}" + (f" ({result.seconds:.1f} s)" if result.rebuilt else ""))
    return 0

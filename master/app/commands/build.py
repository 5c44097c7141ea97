"""`tiltload build`: every FMU into fmus/ (only what is missing or stale), with a binary per platform."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

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
    b.add_argument("--out", type=Path, default=DEFAULT_FMU_DIR, help="output folder (default: fmus)")
    b.add_argument("--force", action="store_true", help="rebuild even if up to date")
    b.add_argument("--platforms", type=platform_list, metavar="LIST",
                   help="comma-separated binaries to build: linux64, win64, aarch64-linux (default: each whose "
                        "compiler is installed; docs/platforms.md)")
    b.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ....native_fmu.compile import choose
    from ..fmus import build_many, formation_recipes, loop_recipes

    toolchains, missing = choose(args.platforms)
    if missing:
        print(f"tiltload build: {missing}", file=sys.stderr)
    recipes = {r.fmu_name: r for r in [*loop_recipes(("load", "uav")), *formation_recipes()]}  # the UAV's plant once
    for result in build_many(list(recipes.values()), args.out, args.force, toolchains=toolchains):
        print(f"{result.path}: {'built' if result.rebuilt else 'up to date'}" + (f" ({result.seconds:.1f} s)" if result.rebuilt else ""))
    return 0

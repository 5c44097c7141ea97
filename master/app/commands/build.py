"""`tiltload build`: every FMU into fmus/ (only what is missing or stale)."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..arguments import DEFAULT_FMU_DIR


def add_parser(sub) -> None:
    b = sub.add_parser("build", help="build the FMUs into fmus/ (only what is missing or stale)")
    b.add_argument("--out", type=Path, default=DEFAULT_FMU_DIR, help="output folder (default: fmus)")
    b.add_argument("--force", action="store_true", help="rebuild even if up to date")
    b.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..fmus import build_many, formation_recipes, loop_recipes

    recipes = {r.fmu_name: r for r in [*loop_recipes(("load", "uav")), *formation_recipes()]}  # the UAV's plant once
    for result in build_many(list(recipes.values()), args.out, args.force):
        print(f"{result.path}: {'built' if result.rebuilt else 'up to date'}" + (f" ({result.seconds:.1f} s)" if result.rebuilt else ""))
    return 0

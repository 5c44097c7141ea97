"""`tiltload build`: every FMU into fmus/ (only what is missing or stale); `--fmi 3`: the FMI 3.0 set into fmus/fmi3/."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..arguments import DEFAULT_FMU_DIR


def add_parser(sub) -> None:
    b = sub.add_parser("build", help="build the FMUs into fmus/ (only what is missing or stale)")
    b.add_argument("--out", type=Path, default=DEFAULT_FMU_DIR, help="output folder (default: fmus)")
    b.add_argument("--force", action="store_true", help="rebuild even if up to date")
    b.add_argument("--fmi", type=int, choices=(2, 3), default=2,
                   help="FMI version: 2 (default) into OUT/; 3: FMI 3.0 co-simulation into OUT/fmi3/, the plain FMUs and "
                        "the sensors' and controllers' variants with clocks (*Clocked.fmu; docs/fmi3.md)")
    b.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ....native_fmu.build import build
    from ..fmus import clocked_recipes, fmu_folder, formation_recipes, loop_recipes

    every = [*loop_recipes(("load", "uav")), *formation_recipes(), *(clocked_recipes() if args.fmi == 3 else ())]
    recipes = {r.fmu_name: r for r in every}  # the UAV's plant once
    out = fmu_folder(args.out, args.fmi)
    for recipe in recipes.values():
        result = build(recipe, out, args.force, fmi_version=args.fmi)
        print(f"{result.path}: {'built' if result.rebuilt else 'up to date'} ({result.seconds:.1f} s)")
    return 0

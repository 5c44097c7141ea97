"""The FMUs of the tiltload loops: which recipes exist, building them, and which FMUs tiltload built itself."""

from __future__ import annotations

import dataclasses
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from ...controller_fmu.fmu import build as controller
from ...formation import build as formation
from ...native_fmu.build import BuildResult, Recipe, build, digest, is_current
from ...native_fmu.compile import choose
from ...native_fmu.package import read_build_info
from ...plant_fmu import build as plant
from ...scenario_fmu import build as scenario
from ...sensor_fmu import build as sensors


def loop_recipes(vehicles=("load",)) -> list[Recipe]:
    """Plant, sensors, scenario, controller (in that order) of each vehicle ("load", "uav")."""
    out = []
    for v in vehicles:
        out += [plant.recipe(v), sensors.recipe(v)]
    out.append(scenario.recipe())
    out += [controller.recipe(v) for v in vehicles]
    return out


def formation_recipes() -> list[Recipe]:
    """The UAV alone's plant, the formation controller and the tracker (Appendix B)."""
    return [plant.recipe("uav"), *formation.recipes()]


def build_all(dest: Path, force: bool = False, progress=print, vehicles=("load",)) -> list[BuildResult]:
    """The loop's FMUs of each vehicle into dest; each is rebuilt only if stale."""
    return build_many(loop_recipes(vehicles), dest, force, progress)


def build_formation(dest: Path, force: bool = False, progress=print) -> list[BuildResult]:
    return build_many(formation_recipes(), dest, force, progress)


def build_many(recipes: list[Recipe], dest: Path, force: bool = False, progress=print, toolchains=()) -> list[BuildResult]:
    """Every stale FMU of recipes rebuilt into dest, in the order given. The C compiler runs for several FMUs side by
    side (a first build is mostly compiling: ~20 s in a row on 2 cores, ~11 s side by side); their Python preparation
    (CasADi code generation, the designs) runs one at a time, as CasADi is not known to be thread-safe."""
    dest = Path(dest)
    toolchains = toolchains or choose()[0]
    stale = [r for r in recipes if force or not is_current(dest / r.fmu_name, digest(r, toolchains))]
    if not stale:
        return [BuildResult(dest / r.fmu_name, False, 0.0) for r in recipes]
    progress(f"building {', '.join(r.fmu_name for r in stale)} into {dest}/ (C compiled side by side) ...")
    one_at_a_time = threading.Lock()

    def alone(prepare):
        def run(folder, say):
            with one_at_a_time:
                return prepare(folder, say)
        return run

    def one(recipe: Recipe) -> BuildResult:
        started = time.perf_counter()
        result = build(dataclasses.replace(recipe, prepare=alone(recipe.prepare)), dest, force, progress, toolchains)
        if result.rebuilt:
            progress(f"  built {recipe.fmu_name} ({time.perf_counter() - started:.1f} s)")
        return result

    with ThreadPoolExecutor(max_workers=len(stale), thread_name_prefix="tiltload-build") as pool:
        futures = {r.fmu_name: pool.submit(one, r) for r in stale}
        results = {name: f.result() for name, f in futures.items()}  # the first failure is raised, after all ended
    return [results.get(r.fmu_name) or BuildResult(dest / r.fmu_name, False, 0.0) for r in recipes]


def is_ours(fmu: Path, md) -> bool:
    """A native FMU tiltload compiled (its build record names the GUID the model description declares)."""
    info = read_build_info(Path(fmu))
    return bool(info) and "wrapped" not in info and info.get("guid") == md.guid


def is_foreign(fmu: Path, md) -> bool:
    """The isolation policy of a run: every FMU tiltload did not compile runs in a worker process of its own."""
    return not is_ours(fmu, md)

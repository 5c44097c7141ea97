"""The FMUs of the tiltload loops: which recipes exist, building them, and which FMUs tiltload built itself."""

from __future__ import annotations

import dataclasses
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from ....controller_fmu.fmu import build as controller
from ....formation import build as formation
from ....native_fmu.build import BuildResult, Recipe, build, digest, inputs_record, is_current, rebuild_reason
from ....native_fmu.cache import cache_root, cached_fmu, newest_cached
from ....native_fmu.compile import choose
from ....native_fmu.package import read_build_info
from ....plant_fmu import build as plant
from ....scenario_fmu import build as scenario
from ....sensor_fmu import build as sensors

FMI3_FOLDER = "fmi3"  # the FMI 3.0 set lives beside the FMI 2.0 one: fmus/fmi3/ (the same file names)


def fmu_folder(base: Path, fmi_version: int = 2) -> Path:
    """Where a set of FMUs lives: the FMI 2.0 set in base (fmus/), the FMI 3.0 set in base/fmi3/."""
    return Path(base) if fmi_version == 2 else Path(base) / FMI3_FOLDER


def loop_recipes(vehicles=("load",), clocked: bool = False) -> list[Recipe]:
    """Plant, sensors, scenario, controller (in that order) of each vehicle ("load", "uav"); clocked: the sensors'
    and the controller's FMI 3.0 variants with clocks (the plant and the scenario have none)."""
    out = []
    for v in vehicles:
        out += [plant.recipe(v), sensors.recipe(v, clocked)]
    out.append(scenario.recipe())
    out += [controller.recipe(v, clocked) for v in vehicles]
    return out


def clocked_recipes(vehicles=("load", "uav")) -> list[Recipe]:
    """The FMI 3.0 variants with clocks: the sensors (a clock per group) and the controller (T_c) of each vehicle."""
    return [r for v in vehicles for r in (sensors.recipe(v, True), controller.recipe(v, True))]


def scheduled_recipes(vehicles=("load", "uav")) -> list[Recipe]:
    """The controller's FMI 3.0 Scheduled Execution variant of each vehicle (docs/fmi3.md, "Scheduled Execution")."""
    return [controller.recipe(v, scheduled=True) for v in vehicles]


def formation_recipes() -> list[Recipe]:
    """The UAV alone's plant, the formation controller and the tracker (Appendix B)."""
    return [plant.recipe("uav"), *formation.recipes()]


def every_recipe(fmi_version: int = 2) -> list[Recipe]:
    """What `tiltload build` builds: both vehicles' loops and the formation; with FMI 3.0, the variants with clocks and
    the Scheduled Execution controllers too."""
    fmi3_only = [*clocked_recipes(), *scheduled_recipes()] if fmi_version == 3 else []
    every = [*loop_recipes(("load", "uav")), *formation_recipes(), *fmi3_only]
    return list({r.fmu_name: r for r in every}.values())  # the UAV's plant once


def build_every(base: Path, fmi_version: int = 2, toolchains=(), force: bool = False, progress=print) -> list[BuildResult]:
    """Every FMU of every_recipe into its folder under base (fmu_folder), for the platforms of toolchains."""
    return build_many(every_recipe(fmi_version), fmu_folder(base, fmi_version), force, progress, toolchains=toolchains,
                      fmi_version=fmi_version)


def build_all(dest: Path, force: bool = False, progress=print, vehicles=("load",), fmi_version: int = 2,
              clocked: bool = False) -> list[BuildResult]:
    """The loop's FMUs of each vehicle into dest (FMI 2.0 or 3.0, with clocks or not); each rebuilt only if stale."""
    return build_many(loop_recipes(vehicles, clocked), dest, force, progress, fmi_version=fmi_version)


def build_formation(dest: Path, force: bool = False, progress=print) -> list[BuildResult]:
    return build_many(formation_recipes(), dest, force, progress)


def build_many(recipes: list[Recipe], dest: Path, force: bool = False, progress=print, toolchains=(),
               fmi_version: int = 2) -> list[BuildResult]:
    """Every stale FMU of recipes rebuilt into dest (as FMI 2.0 or 3.0), in the order given. The C compiler runs for several FMUs side by
    side (a first build is mostly compiling: ~20 s in a row on 2 cores, ~11 s side by side); their Python preparation
    (CasADi code generation, the designs) runs one at a time, as CasADi is not known to be thread-safe."""
    from ..output_folder import folder_problem
    from ..user_error import UserError

    dest = Path(dest)
    problem = folder_problem(dest)
    if problem is not None:  # the API's fmus= too, not only --fmus
        raise UserError(f"the FMU folder {problem}")
    toolchains = toolchains or choose()[0]
    stale = [r for r in recipes if force or not is_current(dest / r.fmu_name, digest(r, toolchains, fmi_version))]
    if not stale:
        return [BuildResult(dest / r.fmu_name, False, 0.0) for r in recipes]
    def reusable(r: Recipe) -> bool:  # a cached copy that is whole (a damaged one is built again: not "reused")
        key = digest(r, toolchains, fmi_version)
        return is_current(cached_fmu(r.fmu_name, key), key)

    cached = [r for r in stale if not force and reusable(r)]
    if cached:
        progress(f"reusing {', '.join(r.fmu_name for r in cached)} from this machine's FMU cache ({cache_root() / 'fmus'}/: "
                 "built before from the same sources, compilers and options)")
    if len(cached) < len(stale):
        building = [r for r in stale if r not in cached]
        progress(f"building {', '.join(r.fmu_name for r in building)} into {dest}/ (C compiled side by side): "
                 f"{why(building, dest, force, toolchains, fmi_version)} ...")
    one_at_a_time = threading.Lock()

    def alone(prepare):
        def run(folder, say):
            with one_at_a_time:
                return prepare(folder, say)
        return run

    def one(recipe: Recipe) -> BuildResult:
        started = time.perf_counter()
        result = build(dataclasses.replace(recipe, prepare=alone(recipe.prepare)), dest, force, progress, toolchains,
                       fmi_version)
        if result.rebuilt:
            progress(f"  built {recipe.fmu_name} ({time.perf_counter() - started:.1f} s)")
        return result

    with ThreadPoolExecutor(max_workers=len(stale), thread_name_prefix="tiltload-build") as pool:
        futures = {r.fmu_name: pool.submit(one, r) for r in stale}
        results = {name: f.result() for name, f in futures.items()}  # the first failure is raised, after all ended
    return [results.get(r.fmu_name) or BuildResult(dest / r.fmu_name, False, 0.0) for r in recipes]


def why(stale: list[Recipe], dest: Path, force: bool, toolchains, fmi_version: int) -> str:
    """One line saying why the stale FMUs are built: each distinct reason once, with the FMUs it concerns when they
    differ (a changed compiler set concerns all; a changed source file, only the FMUs built from it)."""
    reasons: dict[str, list[str]] = {}
    for r in stale:
        record = inputs_record(r, toolchains, fmi_version)
        said = rebuild_reason(dest / r.fmu_name, record, force) or "its inputs changed"
        other = newest_cached(r.fmu_name) if said == "not built yet" else None
        if other is not None:  # a new folder: why the machine's build is not this one's
            said = f"not built yet here; this machine's FMU cache has builds of other inputs only ({rebuild_reason(other, record)})"
        reasons.setdefault(said, []).append(r.fmu_name.removesuffix(".fmu"))
    if len(reasons) == 1:
        return next(iter(reasons))
    return "; ".join(f"{', '.join(names)}: {said}" for said, names in reasons.items())


def is_ours(fmu: Path, md) -> bool:
    """A native FMU tiltload compiled (its build record names the GUID the model description declares)."""
    info = read_build_info(Path(fmu))
    return bool(info) and "wrapped" not in info and info.get("guid") == md.guid


def is_foreign(fmu: Path, md) -> bool:
    """The isolation policy of a run: every FMU tiltload did not compile runs in a worker process of its own."""
    return not is_ours(fmu, md)

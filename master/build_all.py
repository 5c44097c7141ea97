"""Build every FMU of the pipeline into one folder, sharing one compiled model library."""

from __future__ import annotations

from pathlib import Path

from ..controller_fmu.cache import cache_root
from ..plant_fmu.build import BuildResult


def build_all(dest: Path, force: bool = False, progress=print, vehicles=("load",)) -> list[BuildResult]:
    """Plant, sensors, scenario, controller (in that order) of each vehicle ("load", "uav"); each is rebuilt only if stale."""
    from ..controller_fmu import build as controller
    from ..plant_fmu import build as plant
    from ..scenario_fmu import build as scenario
    from ..sensor_fmu import build as sensors

    cache = cache_root()
    results = []
    for v in vehicles:
        results += [plant.build(dest, force=force, vehicle=v), sensors.build(dest, cache, force=force, vehicle=v)]
    results.append(scenario.build(dest, cache, force=force))
    for v in vehicles:
        results.append(controller.build(dest, cache, force=force, progress=progress, vehicle=v))
    return results

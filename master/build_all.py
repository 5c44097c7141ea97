"""Build every FMU of the pipeline into one folder, sharing one compiled model library."""

from __future__ import annotations

from pathlib import Path

from ..controller_fmu.cache import cache_root
from ..plant_fmu.build import BuildResult


def build_all(dest: Path, force: bool = False, progress=print) -> list[BuildResult]:
    """Plant, sensors, scenario, controller (in that order); each is rebuilt only if stale."""
    from ..controller_fmu import build as controller
    from ..plant_fmu import build as plant
    from ..scenario_fmu import build as scenario
    from ..sensor_fmu import build as sensors

    cache = cache_root()
    return [plant.build(dest, force=force), sensors.build(dest, cache, force=force),
            scenario.build(dest, cache, force=force), controller.build(dest, cache, force=force, progress=progress)]

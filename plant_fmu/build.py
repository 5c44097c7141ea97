"""The native plant FMU (with the load, or the UAV alone) as a build recipe: the model's C generated with CasADi,
the trim solved, the hooks compiled with the FMI layer (native_fmu.build)."""

from __future__ import annotations

from functools import partial
from pathlib import Path

import casadi as ca
import numpy as np

from ..native_fmu.build import Prepared, Recipe, tiltload_version
from ..native_fmu.compile import NativeSources
from . import codegen, fmu_variables
from .linearize import linearize
from .trim import hover_trim
from .vehicles import VEHICLES

HERE = Path(__file__).parent
FMU_NAMES = {"load": "TiltloadPlant.fmu", "uav": "TiltrotorUAV.fmu"}
FMU_NAME = FMU_NAMES["load"]
MODEL_C = [HERE / "c" / "plant_model.c", HERE / "c" / "plant_model.h"]
DEFAULT_INTEGRATOR_STEP = 0.004  # 3 RK4 substeps per 12 ms; accuracy table in docs/plant.md


def recipe(vehicle: str = "load") -> Recipe:
    return Recipe(FMU_NAMES[vehicle], (*sorted(HERE.glob("*.py")), *MODEL_C), (ca.__version__, vehicle),
                  partial(_prepare, vehicle))


def _prepare(vehicle: str, folder: Path, progress) -> Prepared:
    v = VEHICLES[vehicle]
    p = v.default_parameters()
    trim = hover_trim(p, vehicle=vehicle)
    eig = np.linalg.eigvals(linearize(trim.x, trim.u, p, vehicle=vehicle).A)
    info = {"integrator_step": DEFAULT_INTEGRATOR_STEP, "casadi": ca.__version__,
            "trim": {"x": trim.x.tolist(), "u": trim.u.tolist(), "residual": trim.residual},
            "open_loop_eigenvalues": [[float(e.real), float(e.imag)] for e in eig]}
    definition = fmu_variables.definition(trim.x, trim.u, DEFAULT_INTEGRATOR_STEP, tiltload_version(), v)
    layout = folder / "plant_layout.h"
    layout.write_text(fmu_variables.layout_header(v))
    generated = [*codegen.plant_sources(folder, vehicle), layout]
    return Prepared(definition, NativeSources(MODEL_C, generated, [f"{codegen.PLANT_STEM}.c"]), info)

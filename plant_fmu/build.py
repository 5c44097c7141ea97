"""Build a native plant FMU (with the load, or the UAV alone): generate the model's C with CasADi,
solve the trim, compile with the FMI layer."""

from __future__ import annotations

import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import casadi as ca
import numpy as np

from ..master import packaging
from ..native_fmu import build as native
from . import codegen, fmu_variables
from .linearize import linearize
from .trim import hover_trim
from .vehicles import VEHICLES

HERE = Path(__file__).parent
FMU_NAME = "TiltloadPlant.fmu"
FMU_NAMES = {"load": FMU_NAME, "uav": "TiltrotorUAV.fmu"}
MODEL_C = [HERE / "c" / "plant_model.c", HERE / "c" / "plant_model.h"]
DEFAULT_INTEGRATOR_STEP = 0.004  # 3 RK4 substeps per 12 ms; accuracy table in docs/plant.md


@dataclass
class BuildResult:
    path: Path
    rebuilt: bool
    seconds: float
    warnings: list[str] = field(default_factory=list)


def digest(vehicle: str = "load") -> str:
    return native.digest([*HERE.glob("*.py"), *MODEL_C], ca.__version__, packaging.tiltload_version(), vehicle)


def build(dest: Path, force: bool = False, vehicle: str = "load") -> BuildResult:
    """Write fmus/TiltloadPlant.fmu (or TiltrotorUAV.fmu) unless an FMU of the same sources is already there."""
    started = time.perf_counter()
    target = Path(dest) / FMU_NAMES[vehicle]
    source_digest = digest(vehicle)
    if not force and native.is_current(target, source_digest):
        return BuildResult(target, False, time.perf_counter() - started)
    v = VEHICLES[vehicle]
    p = v.default_parameters()
    trim = hover_trim(p, vehicle=vehicle)
    eig = np.linalg.eigvals(linearize(trim.x, trim.u, p, vehicle=vehicle).A)
    info = {"version": packaging.tiltload_version(), "integrator_step": DEFAULT_INTEGRATOR_STEP, "casadi": ca.__version__,
            "trim": {"x": trim.x.tolist(), "u": trim.u.tolist(), "residual": trim.residual},
            "open_loop_eigenvalues": [[float(e.real), float(e.imag)] for e in eig]}
    definition = fmu_variables.definition(trim.x, trim.u, DEFAULT_INTEGRATOR_STEP, packaging.tiltload_version(), v)
    with tempfile.TemporaryDirectory(prefix="tiltload_plant_") as tmp:
        layout = Path(tmp) / "plant_layout.h"
        layout.write_text(fmu_variables.layout_header(v))
        generated = [*codegen.plant_sources(Path(tmp), vehicle), layout]
        built = native.build_fmu(definition, native.NativeSources(MODEL_C, generated), target, source_digest, info)
    return BuildResult(target, True, time.perf_counter() - started, built.warnings)

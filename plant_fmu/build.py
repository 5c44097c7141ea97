"""Build the plant FMU: generate and compile the model, solve the trim, package with pythonfmu."""

from __future__ import annotations

import platform
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import casadi as ca
import numpy as np

from ..master import packaging
from . import codegen
from . import parameters as P
from .linearize import linearize
from .trim import hover_trim

HERE = Path(__file__).parent
FMU_NAME = "TiltloadPlant.fmu"
RUNTIME_FILES = ("__init__.py", "interface.py", "parameters.py", "native.py")
DEFAULT_INTEGRATOR_STEP = 0.004  # 3 RK4 substeps per 12 ms; accuracy table in docs/plant.md


@dataclass
class BuildResult:
    path: Path
    rebuilt: bool
    seconds: float


def _digest() -> str:
    import pythonfmu

    sources = sorted(HERE.glob("*.py")) + [Path(packaging.__file__)]
    return packaging.source_hash(sources, ca.__version__, pythonfmu.__version__, platform.machine())


def build(dest: Path, force: bool = False) -> BuildResult:
    """Write fmus/TiltloadPlant.fmu unless an FMU of the same sources is already there."""
    started = time.perf_counter()
    target = Path(dest) / FMU_NAME
    digest = _digest()
    if not force and packaging.is_current(target, digest):
        return BuildResult(target, False, time.perf_counter() - started)
    p = P.default_vector()
    trim = hover_trim(p)
    lin = linearize(trim.x, trim.u, p)
    eig = np.linalg.eigvals(lin.A)
    with tempfile.TemporaryDirectory(prefix="tiltload_plant_") as tmp:
        gen = Path(tmp)
        lib = codegen.compile_library(gen)
        sources = sorted(gen.glob("*.c")) + sorted(gen.glob("*.h"))
        info = {
            "version": packaging.tiltload_version(),
            "source_hash": digest,
            "library": lib.name,
            "integrator_step": DEFAULT_INTEGRATOR_STEP,
            "casadi": ca.__version__,
            "trim": {"x": trim.x.tolist(), "u": trim.u.tolist(), "residual": trim.residual},
            "open_loop_eigenvalues": [[float(e.real), float(e.imag)] for e in eig],
        }
        packaging.build_python_fmu(
            slave=HERE / "fmu_slave.py",
            unique=f"tiltload_plant_{digest[:10]}",
            package_files=[HERE / f for f in RUNTIME_FILES],
            generated=[lib, *sources],
            build_info=info,
            target=target,
            platforms=("linux64",),  # the compiled model is built for this machine's platform
        )
    return BuildResult(target, True, time.perf_counter() - started)

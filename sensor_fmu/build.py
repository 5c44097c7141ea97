"""Build the sensor-suite FMU: the suite logic plus the compiled measurement model pi(x)."""

from __future__ import annotations

import platform
import time
from pathlib import Path

import casadi as ca

from ..master import packaging
from ..plant_fmu import codegen
from ..plant_fmu import parameters as P
from ..plant_fmu.build import BuildResult
from ..plant_fmu.trim import hover_trim
from . import measurement

HERE = Path(__file__).parent
PLANT = HERE.parent / "plant_fmu"
FMU_NAME = "TiltloadSensors.fmu"
RUNTIME = [PLANT / "__init__.py", PLANT / "interface.py", PLANT / "native.py", PLANT / "slave_support.py", HERE / "suite.py"]


def build(dest: Path, cache: Path, force: bool = False) -> BuildResult:
    import pythonfmu

    started = time.perf_counter()
    target = Path(dest) / FMU_NAME
    digest = packaging.source_hash([*RUNTIME, HERE / "fmu_slave.py", HERE / "build.py", Path(packaging.__file__)],
                                   codegen.library_digest(), pythonfmu.__version__, platform.machine(), ca.__version__)
    if not force and packaging.is_current(target, digest):
        return BuildResult(target, False, time.perf_counter() - started)
    lib = codegen.cached_library(cache)
    p = P.default_vector()
    trim = hover_trim(p)
    info = {"version": packaging.tiltload_version(), "source_hash": digest, "library": lib.name,
            "trim_x": trim.x.tolist(), "pi_eq": measurement.pi(trim.x, p).tolist(), "params": p.tolist(),
            "l_index": P.index("l")}
    packaging.build_python_fmu(slave=HERE / "fmu_slave.py", unique=f"tiltload_sensors_{digest[:10]}",
                               package_files=RUNTIME, generated=[lib], build_info=info, target=target,
                               platforms=("linux64",))
    return BuildResult(target, True, time.perf_counter() - started)

"""Build the controller+estimator FMU: embed both designs and the estimator matrices, bundle the run-time code."""

from __future__ import annotations

import platform
import tempfile
import time
from pathlib import Path

import casadi as ca
import numpy as np

from ..master import packaging
from ..plant_fmu import codegen
from ..plant_fmu.build import BuildResult
from ..sensor_fmu import measurement
from . import cache as design_cache
from .design import design
from .estimator_setup import augmented_model, lkf_setup, zse_setup

HERE = Path(__file__).parent
PLANT, SENSORS = HERE.parent / "plant_fmu", HERE.parent / "sensor_fmu"
FMU_NAME = "TiltloadController.fmu"
RUNTIME = [PLANT / "__init__.py", PLANT / "interface.py", PLANT / "native.py", PLANT / "slave_support.py", SENSORS / "suite.py",
           HERE / "runtime.py", HERE / "control_law.py", HERE / "lkf.py", HERE / "zse.py", HERE / "zonotope.py"]
TC = 0.012


def bundle(Tc: float = TC, progress=print) -> dict[str, np.ndarray]:
    """Gains of both designs (cached syntheses) and the estimator matrices of Sec. 5.3-5.4."""
    designs = {}
    for kind in ("dlqr", "mixed"):
        cached = design_cache.default_dir().exists() and any(design_cache.default_dir().glob(f"{kind}-*.json"))
        if kind == "mixed" and not cached:
            progress("synthesizing the mixed H2/Hinf design (about 90 s once; cached afterwards) ...")
        designs[kind] = design(kind, Tc, use_cache=True)
    m = augmented_model(Tc)
    lkf, zse = lkf_setup(), zse_setup(m)
    d = designs["dlqr"]
    return {"K_dlqr": designs["dlqr"].K, "K_mixed": designs["mixed"].K, "Tc": np.array(Tc),
            "trim_x": d.trim_x, "trim_u": d.trim_u, "params": d.params,
            "A_nu": m.A, "B_nu": m.B, "H_lkf": lkf.H, "Pw": lkf.Pw, "Pv": lkf.Pv, "P0": lkf.P0,
            "H_zse": zse.H, "y_eq": zse.y_eq, "G_w": zse.G_w, "G_v": zse.G_v, "G_x0": zse.G_x0, "r_max": np.array(zse.r_max)}


def build(dest: Path, cache: Path, force: bool = False, progress=print) -> BuildResult:
    import pythonfmu

    started = time.perf_counter()
    target = Path(dest) / FMU_NAME
    sources = [*RUNTIME, HERE / "fmu_slave.py", HERE / "build.py", Path(packaging.__file__)]
    digest = packaging.source_hash(sources, codegen.library_digest(), pythonfmu.__version__, platform.machine(),
                                   ca.__version__, design_cache.key("all", TC, np.zeros(1)))
    if not force and packaging.is_current(target, digest):
        return BuildResult(target, False, time.perf_counter() - started)
    lib = codegen.cached_library(cache)
    b = bundle(TC, progress)
    info = {"version": packaging.tiltload_version(), "source_hash": digest, "library": lib.name, "Tc": TC,
            "trim_x": b["trim_x"].tolist(), "trim_u": b["trim_u"].tolist(),
            "pi_eq": measurement.pi(b["trim_x"], b["params"]).tolist()}
    with tempfile.TemporaryDirectory(prefix="tiltload_ctrl_") as tmp:
        npz = Path(tmp) / "bundle.npz"
        np.savez(npz, **b)
        packaging.build_python_fmu(slave=HERE / "fmu_slave.py", unique=f"tiltload_controller_{digest[:10]}",
                                   package_files=RUNTIME, generated=[lib, npz], build_info=info, target=target,
                                   platforms=("linux64",))
    return BuildResult(target, True, time.perf_counter() - started)

"""Build the scenario FMU: trajectories and gusts, pure Python at run time."""

from __future__ import annotations

import time
from pathlib import Path

from ..master import packaging
from ..plant_fmu.build import BuildResult

HERE = Path(__file__).parent
FMU_NAME = "TiltloadScenario.fmu"
RUNTIME = [HERE / "__init__.py", HERE.parent / "plant_fmu" / "slave_support.py", HERE / "trajectories.py"]


def build(dest: Path, cache: Path | None = None, force: bool = False) -> BuildResult:
    import pythonfmu

    started = time.perf_counter()
    target = Path(dest) / FMU_NAME
    digest = packaging.source_hash([*RUNTIME, HERE / "fmu_slave.py", HERE / "build.py", Path(packaging.__file__)],
                                   pythonfmu.__version__)
    if not force and packaging.is_current(target, digest):
        return BuildResult(target, False, time.perf_counter() - started)
    info = {"version": packaging.tiltload_version(), "source_hash": digest}
    packaging.build_python_fmu(slave=HERE / "fmu_slave.py", unique=f"tiltload_scenario_{digest[:10]}",
                               package_files=RUNTIME, generated=[], build_info=info, target=target)
    return BuildResult(target, True, time.perf_counter() - started)

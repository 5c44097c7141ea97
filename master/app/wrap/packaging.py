"""Packaging of a Python slave and its bundled code into an FMI 2.0 FMU (pythonfmu), for `tiltload wrap`.

Each FMU gets a module name unique to its kind and build (pythonfmu issue #228; docs/native_fmus.md):
resources/<unique>.py holds the slave class and resources/<unique>_lib/ the project code it
runs, so several FMUs, or two builds of one, can share an interpreter.
"""

from __future__ import annotations

import json
import shutil
import sys
import tempfile
from pathlib import Path

BUILD_INFO = "build_info.json"


def build_python_fmu(
    *,
    slave: Path,
    unique: str,
    package_files: list[Path],
    generated: list[Path],
    build_info: dict,
    target: Path,
) -> Path:
    """Stage slave + bundled code under the unique name and let pythonfmu write target."""
    from pythonfmu.builder import FmuBuilder

    target.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="tiltload_stage_") as tmp:
        stage = Path(tmp)
        script = stage / f"{unique}.py"
        shutil.copy2(slave, script)
        lib = stage / f"{unique}_lib"
        lib.mkdir()
        for f in [*package_files, *generated]:
            shutil.copy2(f, lib / f.name)
        (lib / BUILD_INFO).write_text(json.dumps(build_info, indent=1))
        partial = target.with_name(target.stem + ".partial.fmu")  # pythonfmu wants a .fmu name
        try:
            FmuBuilder.build_FMU(script, dest=partial, project_files=[lib], needsExecutionTool=False)
            partial.replace(target)
        finally:
            # the builder imported the slave from the staging folder; an FMU instantiated
            # later in this process must import its own copy, not this stale one
            if str(stage) in sys.path:
                sys.path.remove(str(stage))
            for name in [m for m in sys.modules if m == unique or m.startswith(f"{unique}_lib")]:
                del sys.modules[name]
    return target

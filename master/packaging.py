"""Generic packaging of a Python slave and its bundled project code into an FMI 2.0 FMU.

Each FMU gets a module name unique to its kind and build (DESIGN §6, pythonfmu issue #228):
resources/<unique>.py holds the slave class and resources/<unique>_lib/ the project code it
runs, so several FMUs, or two builds of one, can share an interpreter.
"""

from __future__ import annotations

import hashlib
import json
import shutil
import sys
import tempfile
import zipfile
from importlib import metadata
from pathlib import Path

BUILD_INFO = "build_info.json"


def tiltload_version() -> str:
    try:
        return metadata.version("tiltload")
    except metadata.PackageNotFoundError:  # running from a source tree without installing
        return "0+unknown"


def source_hash(files: list[Path], *extra: str) -> str:
    """Hash of the files' contents and extra strings (library versions): the build's identity."""
    h = hashlib.sha256()
    for f in sorted(files, key=lambda p: p.name):
        h.update(f.name.encode())
        h.update(f.read_bytes())
    for e in extra:
        h.update(e.encode())
    return h.hexdigest()


def read_build_info(fmu: Path) -> dict | None:
    """The build_info.json bundled in an FMU, or None if there is none or the file is unreadable."""
    try:
        with zipfile.ZipFile(fmu) as z:
            for name in z.namelist():
                if name.startswith("resources/") and name.endswith(f"_lib/{BUILD_INFO}"):
                    return json.loads(z.read(name))
    except (OSError, zipfile.BadZipFile, json.JSONDecodeError):
        return None
    return None


def is_current(fmu: Path, digest: str) -> bool:
    info = read_build_info(fmu) if fmu.exists() else None
    return bool(info) and info.get("source_hash") == digest


def _keep_platforms(fmu: Path, platforms: tuple[str, ...]) -> None:
    """Drop wrapper binaries for platforms the bundled compiled code does not run on."""
    with zipfile.ZipFile(fmu) as z:
        entries = [(i, z.read(i)) for i in z.infolist()]
    with zipfile.ZipFile(fmu, "w", zipfile.ZIP_DEFLATED) as z:
        for info, data in entries:
            parts = info.filename.split("/")
            if parts[0] == "binaries" and len(parts) > 2 and parts[1] not in platforms:
                continue
            z.writestr(info, data)


def build_python_fmu(
    *,
    slave: Path,
    unique: str,
    package_files: list[Path],
    generated: list[Path],
    build_info: dict,
    target: Path,
    platforms: tuple[str, ...] | None = None,
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
            if platforms is not None:
                _keep_platforms(partial, platforms)
            partial.replace(target)
        finally:
            # the builder imported the slave from the staging folder; an FMU instantiated
            # later in this process must import its own copy, not this stale one
            if str(stage) in sys.path:
                sys.path.remove(str(stage))
            for name in [m for m in sys.modules if m == unique or m.startswith(f"{unique}_lib")]:
                del sys.modules[name]
    return target

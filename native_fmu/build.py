"""Every native FMU is built the same way: digest -> stale? -> prepare -> describe + compile -> package.

An FMU package (plant_fmu, sensor_fmu, ...) describes its FMU as a Recipe: the file name, the
files and versions its build depends on, and a `prepare` step that writes the generated C (CasADi
code, data tables) into a folder and returns the variable table, the C sources and the build
record. `build(recipe, dest)` does the rest, and skips it all when the FMU in dest was built from
the same inputs. One signature for every FMU; nothing here knows which FMU it builds.
"""

from __future__ import annotations

import hashlib
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path

from . import compile as cc
from .package import LAYER_FILES, read_build_info, write_fmu
from .variables import FmuDefinition

HERE = Path(__file__).parent
# the toolkit's own files: a change in any of them rebuilds every FMU
TOOLKIT_FILES = (*LAYER_FILES, HERE / "build.py", HERE / "compile.py", HERE / "package.py", HERE / "describe.py",
                 HERE / "describe3.py", HERE / "variables.py", HERE / "units.py")
BuildError = cc.BuildError
NativeSources = cc.NativeSources


def tiltload_version() -> str:
    """The installed package's version (a source tree run without installing says 0+unknown)."""
    try:
        return metadata.version("tiltload")
    except metadata.PackageNotFoundError:
        return "0+unknown"


@dataclass
class Prepared:
    """What a recipe's prepare step produced: the variable table, the C to compile, the build record's extras."""

    definition: FmuDefinition
    sources: NativeSources
    info: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Recipe:
    """How to build one FMU. prepare(folder, progress) writes generated files into folder (a temporary one)."""

    fmu_name: str  # e.g. TiltloadPlant.fmu
    inputs: tuple[Path, ...]  # the files the build reads: their contents are the build's identity
    identity: tuple[str, ...]  # anything else it depends on (the CasADi version, the vehicle)
    prepare: Callable[[Path, Callable[[str], None]], Prepared]


@dataclass
class BuildResult:
    path: Path
    rebuilt: bool
    seconds: float
    warnings: list[str] = field(default_factory=list)  # the compiler's warnings on our own sources (the tests want none)


def digest(recipe: Recipe, toolchains: tuple[cc.Toolchain, ...], fmi_version: int = 2) -> str:
    """Identity of a build: its input files, the toolkit, the platforms with their compilers and flags, the versions
    (FMI's too)."""
    h = hashlib.sha256()
    for f in sorted({*recipe.inputs, *TOOLKIT_FILES}, key=str):
        h.update(f.name.encode() + b"\0" + f.read_bytes())
    fmi = [f"FMI {fmi_version}"] if fmi_version != 2 else []  # FMI 2.0 builds keep the identity they had
    for e in (*cc.identity(toolchains), tiltload_version(), *recipe.identity, *fmi):
        h.update(e.encode() + b"\0")
    return h.hexdigest()


def is_current(fmu: Path, source_digest: str) -> bool:
    info = read_build_info(fmu) if Path(fmu).is_file() else None
    return bool(info) and info.get("source_hash") == source_digest


def build(recipe: Recipe, dest: Path, force: bool = False, progress: Callable[[str], None] = print,
          toolchains: tuple[cc.Toolchain, ...] = (), fmi_version: int = 2) -> BuildResult:
    """Write dest/<recipe.fmu_name> as an FMI 2.0 or 3.0 FMU with a binary for each of toolchains (default: every
    platform whose compiler is here, compile.choose) unless an FMU of the same inputs and platforms is already there
    (or force)."""
    started = time.perf_counter()
    target = Path(dest) / recipe.fmu_name
    toolchains = toolchains or cc.choose()[0]
    source_digest = digest(recipe, toolchains, fmi_version)
    if not force and is_current(target, source_digest):
        return BuildResult(target, False, time.perf_counter() - started)
    with tempfile.TemporaryDirectory(prefix="tiltload_prepare_") as tmp:
        prepared = recipe.prepare(Path(tmp), progress)
        info = {"version": tiltload_version(), **prepared.info}
        warnings = write_fmu(prepared.definition, prepared.sources, target, source_digest, info, toolchains, fmi_version)
    return BuildResult(target, True, time.perf_counter() - started, warnings)


def build_all(recipes: list[Recipe], dest: Path, force: bool = False, progress: Callable[[str], None] = print,
              toolchains: tuple[cc.Toolchain, ...] = (), fmi_version: int = 2) -> list[BuildResult]:
    return [build(r, dest, force, progress, toolchains, fmi_version) for r in recipes]

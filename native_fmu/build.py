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

from . import cache as machine_cache
from . import compile as cc
from .package import LAYER_FILES, read_build_info, write_fmu
from .variables import FmuDefinition

HERE = Path(__file__).parent
# the toolkit's own files: a change in any of them rebuilds every FMU
TOOLKIT_FILES = (*LAYER_FILES, HERE / "build.py", HERE / "compile.py", HERE / "package.py", HERE / "describe_fmi2.py",
                 HERE / "describe_fmi3.py", HERE / "variables.py", HERE / "units.py")
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
    from_cache: bool = False  # copied from the machine's FMU cache (built before, from the same inputs, in another folder)


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


def inputs_record(recipe: Recipe, toolchains: tuple[cc.Toolchain, ...], fmi_version: int = 2) -> dict:
    """What the digest is made of, part by part, kept in the build record: the next build names the part that changed
    (a source file, the set of platforms, a compiler, the version) instead of rebuilding without a word."""
    files = {}
    for f in sorted({*recipe.inputs, *TOOLKIT_FILES}, key=str):
        files[_short_name(f)] = hashlib.sha256(f.read_bytes()).hexdigest()[:16]
    return {"files": files, "platforms": [t.folder for t in toolchains],
            "compilers": {t.folder: cc.compiler_identity(cc.compiler(t)) for t in toolchains},
            "flags": " ".join(cc.CFLAGS + cc.HOT_CFLAGS + cc.user_cflags()), "machine": cc.identity(())[0],
            "version": tiltload_version(), "identity": list(recipe.identity), "fmi": fmi_version}


def _short_name(f: Path) -> str:
    """A file as the tree names it (plant_fmu/model.py), not by the machine's absolute path."""
    try:
        return Path(f).resolve().relative_to(HERE.parent).as_posix()
    except ValueError:
        return Path(f).name


def rebuild_reason(fmu: Path, record: dict, force: bool = False) -> str | None:
    """Why the FMU at fmu must be built (None: it is current for the inputs record describes): which part changed."""
    if force:
        return "--force"
    info = read_build_info(fmu) if Path(fmu).is_file() else None
    if not Path(fmu).is_file():
        return "not built yet"
    if not info:
        return "the file there is not a tiltload build"
    old = info.get("inputs")
    if not isinstance(old, dict):
        return "built by a tiltload that kept no record of its inputs"
    return _changes(old, record)


def _changes(old: dict, new: dict) -> str | None:
    said = []
    if old.get("platforms") != new["platforms"]:
        said.append(f"the platforms changed ({', '.join(old.get('platforms') or ['none'])} -> {', '.join(new['platforms'])}; "
                    "the set of compilers found here)")
    else:
        moved = [p for p in new["compilers"] if (old.get("compilers") or {}).get(p) != new["compilers"][p]]
        if moved:
            said.append(f"the {', '.join(moved)} compiler changed ({new['compilers'][moved[0]]})")
    files_old, files_new = old.get("files") or {}, new["files"]
    changed = [f for f in files_new if files_old.get(f) != files_new[f]] + [f for f in files_old if f not in files_new]
    if changed:
        shown = ", ".join(changed[:3]) + (f" and {len(changed) - 3} more" if len(changed) > 3 else "")
        said.append(f"source changed: {shown}")
    for key, what in (("version", "tiltload's version"), ("flags", "the compiler flags ($TILTLOAD_CFLAGS)"),
                      ("machine", "the machine"), ("identity", "the model's settings or library versions"),
                      ("fmi", "the FMI version")):
        if old.get(key) != new[key]:
            said.append(f"{what} changed" + (f" ({old.get(key)} -> {new[key]})" if key in ("version", "fmi") else ""))
    return "; ".join(said) or None


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
    if not force and machine_cache.fetch(recipe.fmu_name, source_digest, target) and is_current(target, source_digest):
        return BuildResult(target, False, time.perf_counter() - started, from_cache=True)
    with tempfile.TemporaryDirectory(prefix="tiltload_prepare_") as tmp:
        prepared = recipe.prepare(Path(tmp), progress)
        info = {"version": tiltload_version(), **prepared.info, "inputs": inputs_record(recipe, toolchains, fmi_version)}
        warnings = write_fmu(prepared.definition, prepared.sources, target, source_digest, info, toolchains, fmi_version)
    machine_cache.keep(target, source_digest)
    return BuildResult(target, True, time.perf_counter() - started, warnings)


def build_all(recipes: list[Recipe], dest: Path, force: bool = False, progress: Callable[[str], None] = print,
              toolchains: tuple[cc.Toolchain, ...] = (), fmi_version: int = 2) -> list[BuildResult]:
    return [build(r, dest, force, progress, toolchains, fmi_version) for r in recipes]

"""Compile a native FMU with the system C compiler and package it: no Python inside, libc/libm only.

The FMU holds modelDescription.xml, binaries/linux64/<id>.so, every C source and header it was
built from under sources/ (listed in the model description, so another platform can rebuild it)
and resources/build_info.json (the source digest that decides staleness).
"""

from __future__ import annotations

import hashlib
import json
import os
import platform
import shlex
import shutil
import subprocess
import tempfile
import zipfile
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path

from . import describe
from .variables import FmuDefinition

HERE = Path(__file__).parent
LAYER = HERE / "c"
LAYER_FILES = (LAYER / "tl_fmi2.c", LAYER / "tl_fmu.h", LAYER / "tl_noise.h", LAYER / "tl_platform.h")
FMI_HEADERS = ("fmi2Functions.h", "fmi2FunctionTypes.h", "fmi2TypesPlatform.h")
BUILD_INFO = "resources/build_info.json"
# Portable optimisation (no -march=native: the binary ships); only the fmi2 symbols are exported.
CFLAGS = ("-std=c11", "-O2", "-fPIC", "-fvisibility=hidden", "-Wall", "-Wextra", "-DCASADI_SYMBOL_EXPORT=")
# CasADi's generated code trips -Wextra's unused-parameter and similar: its warnings are not ours.
GENERATED_CFLAGS = ("-Wno-unused-parameter", "-Wno-unused-variable", "-Wno-unused-function")
# Hot numerical kernels (the ZSE's products): full vectorization. No -ffp-contract=fast: the sources pin
# contraction off (tl_platform.h), and clang would let that flag override them.
HOT_CFLAGS = ("-O3",)


def user_cflags() -> tuple[str, ...]:
    """$TILTLOAD_CFLAGS, appended to every compile and part of the build's identity. Example:
    -DTL_PORTABLE_FP drops the AVX2/FMA clones, so the controller rounds as on any x86-64."""
    return tuple(shlex.split(os.environ.get("TILTLOAD_CFLAGS", "")))


class BuildError(RuntimeError):
    """The C compiler or the packaging failed; the message names the file and the compiler's words."""


@dataclass
class NativeSources:
    """What one FMU is compiled from besides the generic layer: hand-written and generated C."""

    model: list[Path]  # hand-written hooks and headers, ours: compiled with every warning on
    generated: list[Path] = field(default_factory=list)  # CasADi output
    hot: list[str] = field(default_factory=list)  # names of C files compiled with HOT_CFLAGS


@dataclass
class NativeBuild:
    path: Path
    warnings: list[str]  # the compiler's warnings on our own sources (the tests want none)


def platform_folder() -> str:
    if platform.system() != "Linux":
        raise BuildError(f"native FMUs are built for Linux here, not {platform.system()}")
    return "linux64" if platform.architecture()[0] == "64bit" else "linux32"


def compiler() -> str:
    cc = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    if not cc:
        raise BuildError("building the FMUs needs a C compiler (cc or gcc) on PATH")
    return cc


@cache
def compiler_identity(cc: str) -> str:
    try:
        return subprocess.run([cc, "--version"], capture_output=True, text=True, check=True).stdout.splitlines()[0]
    except (OSError, subprocess.CalledProcessError, IndexError) as err:
        raise BuildError(f"the C compiler {cc} does not run: {err}") from None


def fmi_header_dir() -> Path:
    """FMI 2.0 headers as FMPy ships them (the standard's own files)."""
    import fmpy

    folder = Path(fmpy.__file__).parent / "c-code"
    missing = [h for h in FMI_HEADERS if not (folder / h).is_file()]
    if missing:
        raise BuildError(f"FMPy's FMI 2.0 headers are missing: {', '.join(missing)}")
    return folder


def digest(files: list[Path], *extra: str) -> str:
    """Identity of a build: its source files, the layer, the compiler and the flags."""
    h = hashlib.sha256()
    for f in sorted({*files, *LAYER_FILES, Path(__file__), HERE / "describe.py", HERE / "variables.py"}, key=str):
        h.update(f.name.encode() + b"\0" + f.read_bytes())
    for e in (compiler_identity(compiler()), platform.machine(), " ".join(CFLAGS + HOT_CFLAGS + user_cflags()), *extra):
        h.update(e.encode() + b"\0")
    return h.hexdigest()


def read_build_info(fmu: Path) -> dict | None:
    try:
        with zipfile.ZipFile(fmu) as z:
            return json.loads(z.read(BUILD_INFO))
    except (OSError, KeyError, zipfile.BadZipFile, json.JSONDecodeError):
        return None


def is_current(fmu: Path, source_digest: str) -> bool:
    info = read_build_info(fmu) if Path(fmu).is_file() else None
    return bool(info) and info.get("source_hash") == source_digest


def _first_error(said: str) -> str:
    """The compiler's first error line: the one a user needs (the rest is context)."""
    lines = [ln.strip() for ln in said.splitlines() if ln.strip()]
    return next((ln for ln in lines if "error" in ln), lines[-1] if lines else "no message")


def _compile(cc: str, source: Path, obj: Path, include: list[Path], extra: tuple[str, ...]) -> str:
    cmd = [cc, *CFLAGS, *extra, *user_cflags(), *(f"-I{d}" for d in include), "-c", str(source), "-o", str(obj)]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        raise BuildError(f"compiling {source.name} with {cc} failed: {_first_error(proc.stderr)}")
    return proc.stderr.strip()


def compile_shared(sources: NativeSources, folder: Path, output: Path, cc: str | None = None,
                   extra_flags: tuple[str, ...] = ()) -> list[str]:
    """Compile the C files of folder (layer + model + generated) into the shared library output."""
    cc = cc or compiler()
    include = [folder]
    objs, warnings = [], []
    generated = {p.name for p in sources.generated}
    for source in sorted(folder.glob("*.c")):
        obj = folder / (source.stem + ".o")
        extra = (*extra_flags, *(GENERATED_CFLAGS if source.name in generated else ()),
                 *(HOT_CFLAGS if source.name in sources.hot else ()))
        said = _compile(cc, source, obj, include, extra)
        if said and source.name not in generated:
            warnings.append(said)
        objs.append(obj)
    link = [cc, "-shared", *extra_flags, "-o", str(output), *map(str, objs), "-lm"]
    if platform.system() == "Linux":  # only fmi2*: -fvisibility=hidden does not hide target_clones' ifunc symbols
        exports = folder / "exports.map"
        exports.write_text("{ global: fmi2*; local: *; };\n")
        link.append(f"-Wl,--version-script={exports}")
    proc = subprocess.run(link, capture_output=True, text=True)
    if proc.returncode != 0:
        raise BuildError(f"linking {output.name} with {cc} failed: {_first_error(proc.stderr)}")
    for obj in objs:
        obj.unlink()
    return warnings


def build_fmu(definition: FmuDefinition, sources: NativeSources, target: Path, source_digest: str,
              info: dict | None = None) -> NativeBuild:
    """Write target: generate the tables, compile, zip. Written under a temporary name, then moved."""
    target = Path(target)
    target.parent.mkdir(parents=True, exist_ok=True)
    guid = describe.guid(definition, source_digest)
    with tempfile.TemporaryDirectory(prefix="tiltload_native_") as tmp:
        stage = Path(tmp)
        src = stage / "sources"
        src.mkdir()
        headers = fmi_header_dir()
        for h in FMI_HEADERS:
            shutil.copy2(headers / h, src / h)
        for f in (*LAYER_FILES, *sources.model, *sources.generated):
            shutil.copy2(f, src / f.name)
        (src / "tl_model.h").write_text(describe.c_header(definition, guid))
        (src / "tl_model_tables.c").write_text(describe.c_tables(definition))
        bin_dir = stage / "binaries" / platform_folder()
        bin_dir.mkdir(parents=True)
        warnings = compile_shared(sources, src, bin_dir / f"{definition.model_identifier}.so")
        c_files = sorted(p.name for p in src.glob("*.c"))
        tool = f"tiltload {definition.version} (native FMI 2.0 layer, {compiler_identity(compiler())})"
        (stage / "modelDescription.xml").write_bytes(describe.model_description(definition, guid, c_files, tool))
        (stage / "resources").mkdir()
        (stage / BUILD_INFO).write_text(json.dumps({"source_hash": source_digest, "guid": guid, **(info or {})}, indent=1))
        partial = target.with_name(target.name + ".partial")
        with zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as z:
            for f in sorted(stage.rglob("*")):
                if f.is_file():
                    z.write(f, f.relative_to(stage).as_posix())
        partial.replace(target)
    return NativeBuild(target, warnings)

"""Compile an FMU's C sources into a shared library with the system C compiler.

Flags: portable optimisation (no -march=native: the binary ships), every warning on for our own
sources, only the FMI API's symbols exported (fmi2* or fmi3*).
"""

from __future__ import annotations

import os
import platform
import shlex
import shutil
import subprocess
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path

CFLAGS = ("-std=c11", "-O2", "-fPIC", "-fvisibility=hidden", "-Wall", "-Wextra", "-DCASADI_SYMBOL_EXPORT=")
# CasADi's generated code trips -Wextra's unused-parameter and similar: its warnings are not ours.
GENERATED_CFLAGS = ("-Wno-unused-parameter", "-Wno-unused-variable", "-Wno-unused-function")
# Hot numerical kernels (the ZSE's products): full vectorization and fused multiply-adds, still portable.
HOT_CFLAGS = ("-O3", "-ffp-contract=fast")


class BuildError(RuntimeError):
    """The C compiler or the packaging failed; the message names the file and the compiler's words."""


@dataclass
class NativeSources:
    """What one FMU is compiled from besides the generic layer: hand-written and generated C."""

    model: list[Path]  # hand-written hooks and headers, ours: compiled with every warning on
    generated: list[Path] = field(default_factory=list)  # CasADi output and generated tables
    hot: list[str] = field(default_factory=list)  # names of C files compiled with HOT_CFLAGS


def user_cflags() -> tuple[str, ...]:
    """$TILTLOAD_CFLAGS, appended to every compile and part of the build's identity. Example:
    -DTL_PORTABLE_FP drops the AVX2/FMA clones, so the controller rounds as on any x86-64."""
    return tuple(shlex.split(os.environ.get("TILTLOAD_CFLAGS", "")))


def platform_folder() -> str:
    if platform.system() != "Linux":
        raise BuildError(f"native FMUs are built for Linux here, not {platform.system()}")
    return "linux64" if platform.architecture()[0] == "64bit" else "linux32"


@dataclass(frozen=True)
class Target:
    """One platform an FMU's binary is built for: where it goes in each FMI version, and what builds it.

    A build takes a list of targets (default: this machine's); a cross compiler plugs in as another entry, e.g.
    Target("x86_64-windows", "win64", "x86_64-w64-mingw32-gcc", ".dll", export_map=False)."""

    platform_tuple: str  # FMI 3.0: binaries/<platform_tuple>/ (x86_64-linux, aarch64-linux, x86_64-windows)
    fmi2_folder: str | None  # FMI 2.0: binaries/<folder>/ (linux64, win64); None where FMI 2.0 has no name
    compiler: str | None = None  # None: the system compiler (compiler())
    suffix: str = ".so"
    export_map: bool = True  # an ELF version script keeps only the API exported (a DLL exports only what it marks)

    def folder(self, fmi_version: int) -> str:
        if fmi_version == 3:
            return self.platform_tuple
        if self.fmi2_folder is None:
            raise BuildError(f"FMI 2.0 has no platform folder for {self.platform_tuple}; build it as FMI 3.0")
        return self.fmi2_folder


def native_target() -> Target:
    """This machine's platform, built with the system compiler."""
    folder = platform_folder()
    machine = {"AMD64": "x86_64", "arm64": "aarch64"}.get(platform.machine(), platform.machine())
    return Target(f"{machine}-linux", folder if machine in ("x86_64", "i686") else None)


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


def identity() -> tuple[str, ...]:
    """What of the toolchain a build's identity includes: the compiler, the machine, the flags."""
    return compiler_identity(compiler()), platform.machine(), " ".join(CFLAGS + HOT_CFLAGS + user_cflags())


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
                   extra_flags: tuple[str, ...] = (), include: tuple[Path, ...] = (), api: str = "fmi2",
                   export_map: bool = True) -> list[str]:
    """Compile the C files of folder (layer + model + generated) into the shared library output, exporting only the
    api's functions (fmi2*, fmi3*); include: header folders besides folder. Return the compiler's warnings on our
    own sources."""
    cc = cc or compiler()
    include = [folder, *include]
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
    if export_map:  # only the API: -fvisibility=hidden does not hide target_clones' ifunc symbols
        exports = folder / "exports.map"
        exports.write_text(f"{{ global: {api}*; local: *; }};\n")
        link.append(f"-Wl,--version-script={exports}")
    proc = subprocess.run(link, capture_output=True, text=True)
    if proc.returncode != 0:
        raise BuildError(f"linking {output.name} with {cc} failed: {_first_error(proc.stderr)}")
    for obj in objs:
        obj.unlink()
    return warnings

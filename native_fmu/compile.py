"""Compile an FMU's C sources into one shared library per platform: this machine's compiler, or a cross compiler.

A platform is a row of TOOLCHAINS: where its binary goes, which compiler builds it, its flags. The
sources need nothing platform-specific (tl_platform.h pins the arithmetic and hides the internals), so
every platform compiles the same files with the same portable flags (no -march=native: the binary
ships), every warning on, only the FMI API exported (fmi2* or fmi3*). FMI 2.0 and FMI 3.0 builds use the same
toolchains; the FMI version only chooses the binaries/ folder (Toolchain.binary_folder).
"""

from __future__ import annotations

import os
import platform
import shlex
import shutil
import subprocess
import tempfile
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path

# The language the sources are written in (docs/platforms.md): every compiler here takes it warning-free.
CFLAGS = ("-std=c99", "-pedantic", "-O2", "-Wall", "-Wextra")
# Hot numerical kernels (the ZSE's products): full vectorization. No -ffp-contract=fast: the sources pin
# contraction off (tl_platform.h), and clang would let that flag override them.
HOT_CFLAGS = ("-O3",)
ELF_CFLAGS = ("-fPIC", "-fvisibility=hidden")  # the sources hide their internals themselves; this is the belt


class BuildError(RuntimeError):
    """The C compiler or the packaging failed; the message names the file and the compiler's words."""


@dataclass
class NativeSources:
    """What one FMU is compiled from besides the generic layer: hand-written and generated C."""

    model: list[Path]  # hand-written hooks and headers
    generated: list[Path] = field(default_factory=list)  # CasADi output and generated tables
    hot: list[str] = field(default_factory=list)  # names of C files compiled with HOT_CFLAGS


@dataclass(frozen=True)
class Toolchain:
    """How one platform's binary is built. The FMI 2.0 layout puts it in binaries/<folder>/<id><suffix>;
    name is the platform as FMI 3.0's tuples say it, the folder of an FMI 3.0 build."""

    name: str  # <machine>-<system>: x86_64-linux, x86_64-windows, aarch64-linux
    folder: str  # FMI 2.0's binaries/ folder (linux64, win64; aarch64-linux as FMI 2.0.4 advises for the rest)
    compiler: str  # the cross compiler; a machine of this platform uses its own compiler ($CC, cc) instead
    package: str  # the Debian packages that provide the compiler (named when it is missing)
    cflags: tuple[str, ...]
    ldflags: tuple[str, ...]
    suffix: str
    export_map: bool  # ELF: a version script exports only the API (a DLL exports only what it marks dllexport)

    def binary_folder(self, fmi_version: int) -> str:
        """binaries/<this>/: FMI 3.0's platform tuple, or FMI 2.0's folder."""
        return self.name if fmi_version == 3 else self.folder


TOOLCHAINS = (
    Toolchain("x86_64-linux", "linux64", "x86_64-linux-gnu-gcc", "gcc", ELF_CFLAGS, ("-lm",), ".so", True),
    # -static: the MinGW runtime (libgcc, libmingwex) inside the DLL, which then imports only KERNEL32.dll and
    # msvcrt.dll; no timestamp, so the same sources give the same DLL byte for byte.
    Toolchain("x86_64-windows", "win64", "x86_64-w64-mingw32-gcc", "gcc-mingw-w64-x86-64", (),
              ("-static", "-Wl,--no-insert-timestamp"), ".dll", False),
    Toolchain("aarch64-linux", "aarch64-linux", "aarch64-linux-gnu-gcc", "gcc-aarch64-linux-gnu libc6-dev-arm64-cross",
              ELF_CFLAGS, ("-lm",), ".so", True),
)


def host_platform() -> str:
    """This machine as a toolchain name: x86_64-linux, aarch64-linux, x86_64-windows ..."""
    machine = {"amd64": "x86_64", "arm64": "aarch64"}.get(platform.machine().lower(), platform.machine().lower())
    return f"{machine}-{platform.system().lower()}"


def toolchain(name: str) -> Toolchain:
    """The platform called name (its toolchain name or its FMI 2.0 folder)."""
    for t in TOOLCHAINS:
        if name in (t.name, t.folder):
            return t
    raise BuildError(f"unknown platform {name!r}: choose from {', '.join(t.folder for t in TOOLCHAINS)}")


def find_compiler(t: Toolchain) -> str | None:
    """The compiler that builds t here: this machine's own for its platform, else the cross compiler on PATH."""
    if t.name == host_platform():
        return os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    return shutil.which(t.compiler)


def compiler(t: Toolchain) -> str:
    cc = find_compiler(t)
    if not cc:
        wanted = "a C compiler (cc or gcc)" if t.name == host_platform() else t.compiler
        raise BuildError(f"the {t.folder} binaries need {wanted} on PATH (Debian: apt-get install {t.package})")
    return cc


def choose(names: list[str] | None = None) -> tuple[tuple[Toolchain, ...], str | None]:
    """The platforms to build and, for the default set, one line naming those left out (None: nothing missing).
    Default: every platform whose compiler is here. Named platforms must all have their compiler."""
    if names:
        chosen = tuple(dict.fromkeys(toolchain(n) for n in names))
        for t in chosen:
            compiler(t)  # asked for explicitly: a missing compiler is an error
        return chosen, None
    chosen = tuple(t for t in TOOLCHAINS if find_compiler(t))
    missing = [t for t in TOOLCHAINS if t not in chosen]
    if not chosen:
        raise BuildError(f"no C compiler for any platform ({host_platform()} here): install gcc")
    note = None
    if missing:
        note = ("no " + ", ".join(t.folder for t in missing) + " binaries: " + ", ".join(t.compiler for t in missing)
                + " not on PATH (Debian: apt-get install " + " ".join(t.package for t in missing) + ")")
    return chosen, note


def user_cflags() -> tuple[str, ...]:
    """$TILTLOAD_CFLAGS, appended to every compile and part of the build's identity. Example:
    -DTL_PORTABLE_FP drops the AVX2 clones, so the controller runs the code path of any x86-64."""
    return tuple(shlex.split(os.environ.get("TILTLOAD_CFLAGS", "")))


@cache
def compiler_identity(cc: str) -> str:
    try:
        return subprocess.run([cc, "--version"], capture_output=True, text=True, check=True).stdout.splitlines()[0]
    except (OSError, subprocess.CalledProcessError, IndexError) as err:
        raise BuildError(f"the C compiler {cc} does not run: {err}") from None


def identity(toolchains: tuple[Toolchain, ...]) -> tuple[str, ...]:
    """What of the toolchains a build's identity includes: each platform's compiler and flags, the machine."""
    out = [platform.machine(), " ".join(CFLAGS + HOT_CFLAGS + user_cflags())]
    for t in toolchains:
        out.append(f"{t!r} {compiler_identity(compiler(t))}")
    return tuple(out)


def _first_error(said: str) -> str:
    """The compiler's first error line: the one a user needs (the rest is context)."""
    lines = [ln.strip() for ln in said.splitlines() if ln.strip()]
    return next((ln for ln in lines if "error" in ln), lines[-1] if lines else "no message")


def _compile(cc: str, source: Path, obj: Path, extra: tuple[str, ...]) -> str:
    """One file, compiled in its folder under its bare name: no build path ends up in the binary."""
    cmd = [cc, *CFLAGS, *extra, *user_cflags(), "-I.", "-c", source.name, "-o", str(obj)]
    proc = subprocess.run(cmd, capture_output=True, text=True, cwd=source.parent)
    if proc.returncode != 0:
        raise BuildError(f"compiling {source.name} with {cc} failed: {_first_error(proc.stderr)}")
    return proc.stderr.strip()


def compile_shared(sources: NativeSources, folder: Path, output: Path, t: Toolchain, jobs: int | None = None,
                   api: str = "fmi2", include: tuple[Path, ...] = ()) -> list[str]:
    """Compile the C files of folder (layer + model + generated) into the shared library output for platform t,
    `jobs` files at a time (default: one per core), exporting only the api's functions (fmi2*, fmi3*); include:
    header folders besides folder (FMI 3.0's headers, which its sources/ does not carry). Return the compiler's
    warnings (the sources have none)."""
    cc = compiler(t)
    includes = tuple(f"-I{Path(d).resolve()}" for d in include)
    files = sorted(folder.glob("*.c"))
    with tempfile.TemporaryDirectory(prefix="tiltload_objects_") as tmp:
        objects = [Path(tmp) / (f.stem + ".o") for f in files]
        with ThreadPoolExecutor(max_workers=jobs or os.cpu_count() or 1) as pool:
            said = list(pool.map(lambda f, o: _compile(cc, f, o, (*t.cflags, *includes, *(
                HOT_CFLAGS if f.name in sources.hot else ()))), files, objects))
        # linked where it goes, under its bare name: MinGW's ld derives a DLL's image base from the output name as
        # given, so a path (a temporary one) would make every build differ
        link = [cc, "-shared", "-o", output.name, *map(str, objects), *t.ldflags]
        if t.export_map:  # only the API, whatever the sources say (they hide the rest themselves)
            exports = Path(tmp) / "exports.map"  # outside the sources: it is not one of them
            exports.write_text(f"{{ global: {api}*; local: *; }};\n")
            link.append(f"-Wl,--version-script={exports}")
        proc = subprocess.run(link, capture_output=True, text=True, cwd=output.parent)
    if proc.returncode != 0:
        raise BuildError(f"linking {output.name} with {cc} failed: {_first_error(proc.stderr)}")
    return [f"{t.folder}: {s}" for s in said if s]

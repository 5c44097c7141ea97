"""Running FMU binaries of other platforms here: hosts/portable_host.c compiled for the platform and run natively,
under wine (win64) or under qemu-user (aarch64-linux), with plans written from the FMUs' model descriptions.

A tool that is missing makes the caller skip with one line naming the Debian package (`need`)."""

from __future__ import annotations

import os
import shutil
import subprocess
import xml.etree.ElementTree as ET
import zipfile
from dataclasses import dataclass
from pathlib import Path, PureWindowsPath

import numpy as np
import pytest

from . import HOSTS

HOST_FLAGS = ("-std=c99", "-O2", "-Wall", "-Wextra", "-pedantic", "-Werror")
AARCH64_SYSROOT = Path("/usr/aarch64-linux-gnu")


@dataclass(frozen=True)
class Platform:
    folder: str  # binaries/<folder>/
    suffix: str
    compiler: str  # builds the host; None-like "cc" for this machine
    host_flags: tuple[str, ...]  # the host's libraries
    runner: tuple[str, ...]  # what runs a program of this platform here (empty: natively)
    packages: dict[str, str]  # tool -> the Debian package that has it
    windows_paths: bool = False


# libm loaded whether the host calls it or not, as in any real importer (Python): a library linked without -lm
# (FMPy's CMake build of sources/) relies on that
LINUX_LIBS = ("-ldl", "-Wl,--no-as-needed", "-lm")
LINUX64 = Platform("linux64", ".so", "cc", LINUX_LIBS, (), {"cc": "gcc"})
WIN64 = Platform("win64", ".dll", "x86_64-w64-mingw32-gcc", ("-static",), ("wine",),
                 {"x86_64-w64-mingw32-gcc": "gcc-mingw-w64-x86-64", "wine": "wine64"}, windows_paths=True)
AARCH64 = Platform("aarch64-linux", ".so", "aarch64-linux-gnu-gcc", LINUX_LIBS,
                   ("qemu-aarch64", "-L", str(AARCH64_SYSROOT)),
                   {"aarch64-linux-gnu-gcc": "gcc-aarch64-linux-gnu", "qemu-aarch64": "qemu-user"})


def need(tool: str, package: str) -> str:
    """The tool's path, or a skip naming the package that has it."""
    path = shutil.which(tool)
    if not path:
        pytest.skip(f"{tool} is not installed (Debian package {package})")
    return path


def need_platform(p: Platform) -> None:
    for tool, package in p.packages.items():
        need(tool, package)
    if p is AARCH64 and not (AARCH64_SYSROOT / "lib").is_dir():
        pytest.skip("the aarch64 C library is not installed (Debian package libc6-dev-arm64-cross)")


def wine_environment(prefix: Path) -> dict[str, str]:
    """Headless wine in its own prefix: no Mono or Gecko prompt, no display, no debug chatter."""
    env = {k: v for k, v in os.environ.items() if k != "DISPLAY"}
    env.update(WINEPREFIX=str(prefix), WINEDEBUG="-all", WINEDLLOVERRIDES="mscoree,mshtml=")
    return env


def native_path(p: Path, platform: Platform) -> str:
    """A path as a program of the platform sees it (wine maps / to Z:)."""
    p = Path(p).resolve()
    return str(PureWindowsPath("Z:" + str(p).replace("/", "\\"))) if platform.windows_paths else str(p)


def resource_uri(p: Path, platform: Platform) -> str:
    p = Path(p).resolve()
    return f"file:///Z:{p}" if platform.windows_paths else f"file://{p}"


def compile_host(platform: Platform, sources: Path, out: Path, compiler: str | None = None) -> Path:
    """hosts/portable_host.c for the platform (the FMI headers from an FMU's sources/), warning-free."""
    need_platform(platform)
    exe = out / f"portable_host_{platform.folder}{'.exe' if platform.windows_paths else ''}"
    proc = subprocess.run([compiler or platform.compiler, *HOST_FLAGS, f"-I{sources}", str(HOSTS / "portable_host.c"),
                           "-o", str(exe), *platform.host_flags], capture_output=True, text=True)
    assert proc.returncode == 0 and not proc.stderr, proc.stderr
    return exe


@dataclass
class Host:
    """A compiled host and how to start it."""

    platform: Platform
    exe: Path
    env: dict[str, str] | None = None

    def run(self, plan: Path, timeout: float = 600) -> Run:
        cmd = [*self.platform.runner, str(self.exe), native_path(plan, self.platform)]
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=self.env)
        assert proc.returncode == 0, f"{' '.join(cmd)}: exit {proc.returncode}\n{proc.stdout[-1500:]}\n{proc.stderr[-1500:]}"
        return Run.parse(proc.stdout)


@dataclass
class Run:
    """A host's output: every printed value by (time, instance, vr), the ISE sums by (instance, vr)."""

    values: dict[tuple[float, str, int], float]
    ise: dict[tuple[str, int], float]

    @staticmethod
    def parse(text: str) -> Run:
        values, ise = {}, {}
        for line in text.splitlines():
            f = line.split()
            if f and f[0] == "v":
                values[float(f[1]), f[2], int(f[3])] = float(f[4])
            elif f and f[0] == "ise":
                ise[f[1], int(f[2])] = float(f[3])
        return Run(values, ise)

    def max_difference(self, other: Run) -> float:
        """max |a - b| over every printed value (the same values must have been printed)."""
        assert self.values and self.values.keys() == other.values.keys()
        a = np.array([self.values[k] for k in self.values])
        b = np.array([other.values[k] for k in self.values])
        return float(np.max(np.abs(a - b)))


def unpack(fmu: Path, dest: Path) -> Path:
    folder = dest / fmu.stem
    if not folder.is_dir():
        with zipfile.ZipFile(fmu) as z:
            z.extractall(folder)
    return folder


def _description(folder: Path) -> ET.Element:
    return ET.parse(folder / "modelDescription.xml").getroot()


def binary(folder: Path, platform: Platform) -> Path:
    ident = _description(folder).find("CoSimulation").get("modelIdentifier")
    return folder / "binaries" / platform.folder / f"{ident}{platform.suffix}"


def fmu_line(name: str, folder: Path, platform: Platform, library: Path | None = None) -> str:
    md = _description(folder)
    lib = library or binary(folder, platform)
    return f"F {name} {native_path(lib, platform)} {md.get('guid')} {resource_uri(folder / 'resources', platform)}"


def single_plan(folder: Path, platform: Platform, out: Path, seconds: float = 2.0, library: Path | None = None,
                tag: str = "shipped") -> Path:
    """The FMU alone with its start values on its default experiment's step for `seconds`: every Real output at
    every step (library: another build of its binary; tag names the plan)."""
    md = _description(folder)
    step = float(md.find("DefaultExperiment").get("stepSize"))
    lines = [fmu_line("fmu", folder, platform, library), f"T {step!r} {round(seconds / step)}", "E 1"]
    lines += [f"O fmu {v.get('valueReference')}" for v in md.find("ModelVariables")
              if v.get("causality") == "output" and v.find("Real") is not None]
    plan = out / f"{folder.name}_{platform.folder}_{tag}.plan"
    plan.write_text("\n".join(lines) + "\n")
    return plan


TRACKED = ("x", "y", "z", "psi")


def loop_plan(system, folders: dict[str, Path], platform: Platform, out: Path, seconds: float, every: int,
              libraries: dict[str, Path] | None = None, global_scope: bool = False) -> tuple[Path, dict[str, int]]:
    """A tiltload system (app.loop.default_system) for the host: its parameters and connections, the ISE of x, y, z,
    psi as tiltload's metrics sample them, every Real output of the plant and the controller every `every` ticks.
    Returns the plan and the plant's value reference of each tracked variable (the keys of Run.ise)."""
    from tiltload.master.engine import connections
    from tiltload.master.engine.fmi.model_description import read_fmu

    mds = {i.name: read_fmu(i.fmu, i.name) for i in system.instances}
    lines = ["G"] if global_scope else []
    for inst in system.instances:
        lines.append(fmu_line(inst.name, folders[inst.name], platform, (libraries or {}).get(inst.name)))
        variables = {v.name: v for v in mds[inst.name].modelVariables}
        for key, value in inst.parameters.items():
            v = variables[key]
            code = {"Real": "R", "Integer": "I", "Boolean": "B", "String": "S"}[v.type]
            text = str(int(value)) if code in "IB" else (repr(float(value)) if code == "R" else str(value))
            lines.append(f"P {inst.name} {code} {v.valueReference} {text}")
    for link in connections.resolve(system, mds):
        assert link.delay == 0
        lines.append(f"C {link.source} {link.type[0]} {link.source_vr} {link.target} {link.target_vr}")
    lines += [f"T {system.tick!r} {round(seconds / system.tick)}", f"E {every}"]
    plant = {v.name: v.valueReference for v in mds["plant"].modelVariables}
    ref = {v.name: v.valueReference for v in mds["scenario"].modelVariables}
    lines += [f"M plant scenario controller {plant[a]} {ref[a + '_ref']}" for a in TRACKED]
    for inst in ("plant", "controller"):
        lines += [f"O {inst} {v.valueReference}" for v in mds[inst].modelVariables
                  if v.causality == "output" and v.type == "Real"]
    plan = out / f"loop_{platform.folder}{'_global' if global_scope else ''}.plan"
    plan.write_text("\n".join(lines) + "\n")
    return plan, {a: plant[a] for a in TRACKED}

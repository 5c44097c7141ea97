"""Every FMU's binaries for Windows (win64, MinGW-w64, run under wine) and Linux aarch64 (run under qemu-user) beside
linux64's, and sources/ that build anywhere: the same results, only the FMI API exported, no warnings
(docs/platforms.md). Each test skips with the missing package's name when a tool is absent."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import supported_platforms
from fmpy.validation import validate_fmu
from support import ROOT
from support.portable import AARCH64, LINUX64, WIN64, Host, binary, compile_host, need, need_platform, single_plan, unpack, wine_environment
from tiltload.native_fmu import compile as cc

FMUS = ("TiltloadPlant", "TiltloadSensors", "TiltloadScenario", "TiltloadController", "TiltrotorUAV", "TiltrotorSensors",
        "TiltrotorController", "FormationController", "TiltrotorTracker")
LOOP = {"plant": "TiltloadPlant", "sensors": "TiltloadSensors", "scenario": "TiltloadScenario",
        "controller": "TiltloadController"}
SAME = 1e-12  # the bound the issue sets for a 2 s run; measured maxima in docs/platforms.md
FMI2_EXPORTS = 34  # every function of fmi2Functions.h
WINDOWS_DLLS = {"kernel32.dll", "msvcrt.dll"}  # Windows' own (msvcrt.dll: the system C runtime MinGW links)


@pytest.fixture(scope="module")
def all_fmus() -> dict[str, Path]:
    """The nine FMUs tiltload builds, with every platform whose compiler is here."""
    from tiltload.master.app.loop.fmus import formation_recipes, loop_recipes
    from tiltload.native_fmu.build import build

    recipes = {r.fmu_name: r for r in [*loop_recipes(("load", "uav")), *formation_recipes()]}
    paths = {Path(name).stem: build(r, ROOT / "fmus", progress=lambda *_: None).path for name, r in recipes.items()}
    assert sorted(paths) == sorted(FMUS)
    return paths


@pytest.fixture(scope="module")
def unpacked(all_fmus, tmp_path_factory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("platforms")
    return {name: unpack(fmu, root) for name, fmu in all_fmus.items()}


@pytest.fixture(scope="module")
def hosts(unpacked, tmp_path_factory):
    """hosts["linux64"|"win64"|"aarch64-linux"]() -> the portable host for that platform (compiled once; a skip
    when its tools are missing); wine runs in a prefix of its own, stopped at the end."""
    out = tmp_path_factory.mktemp("hosts")
    sources = unpacked["TiltloadPlant"] / "sources"
    made: dict[str, Host] = {}
    prefix = out / "wineprefix"

    def get(folder: str) -> Host:
        platform = {"linux64": LINUX64, "win64": WIN64, "aarch64-linux": AARCH64}[folder]
        if folder not in made:
            made[folder] = Host(platform, compile_host(platform, sources, out),
                                wine_environment(prefix) if platform is WIN64 else None)
        return made[folder]
    yield get
    if "win64" in made and shutil.which("wineserver"):
        subprocess.run(["wineserver", "-k"], env=made["win64"].env, capture_output=True, timeout=60)


def _shipped(unpacked, name: str, folder: str) -> Path:
    platform = {"linux64": LINUX64, "win64": WIN64, "aarch64-linux": AARCH64}[folder]
    path = binary(unpacked[name], platform)
    if not path.is_file():
        t = cc.toolchain(folder)
        pytest.skip(f"no {folder} binary was built: {t.compiler} is not installed (Debian package {t.package})")
    return path


# ---- what ships -----------------------------------------------------------------------------------
@pytest.mark.parametrize("name", FMUS)
def test_every_platform_with_a_compiler_ships_a_binary_and_validates(all_fmus, name):
    built = [t.folder for t in cc.TOOLCHAINS if cc.find_compiler(t)]
    with zipfile.ZipFile(all_fmus[name]) as z:
        binaries = sorted(n for n in z.namelist() if n.startswith("binaries/"))
        info = json.loads(z.read("resources/build_info.json"))
    assert binaries == sorted(f"binaries/{t.folder}/{name}{t.suffix}" for t in cc.TOOLCHAINS if t.folder in built)
    assert info["platforms"] == built and info["warnings"] == []  # -std=c99 -pedantic -Wall -Wextra on each platform
    assert validate_fmu(str(all_fmus[name])) == []
    fmi2_folders = {"linux64", "win64"}  # what FMPy names for FMI 2.0; aarch64-linux is FMI 2.0.4's advice
    assert set(supported_platforms(str(all_fmus[name]))) == {"c-code"} | (fmi2_folders & set(built))


@pytest.mark.parametrize("name", FMUS)
def test_dll_exports_the_fmi2_functions_only_and_imports_windows_dlls_only(unpacked, name):
    dll = _shipped(unpacked, name, "win64")
    objdump = need("x86_64-w64-mingw32-objdump", "binutils-mingw-w64-x86-64")
    text = subprocess.run([objdump, "-p", str(dll)], capture_output=True, text=True, check=True).stdout
    table = text.split("[Ordinal/Name Pointer] Table", 1)[1].split("\n\n", 1)[0]
    exported = re.findall(r"\]\s+(\S+)", table)
    assert len(exported) == FMI2_EXPORTS and all(e.startswith("fmi2") for e in exported), exported
    imported = {m.lower() for m in re.findall(r"DLL Name:\s+(\S+)", text)}
    assert imported <= WINDOWS_DLLS, imported  # the MinGW runtime is inside: no libgcc_s, libwinpthread


@pytest.mark.parametrize("folder", ["linux64", "aarch64-linux"])
@pytest.mark.parametrize("name", FMUS)
def test_so_exports_the_fmi2_functions_only_and_needs_libc_and_libm(unpacked, name, folder):
    so = _shipped(unpacked, name, folder)
    prefix = "aarch64-linux-gnu-" if folder == "aarch64-linux" else ""
    nm = need(f"{prefix}nm", f"binutils-{prefix[:-1]}" if prefix else "binutils")
    readelf = need(f"{prefix}readelf", f"binutils-{prefix[:-1]}" if prefix else "binutils")
    exported = _exports(nm, so)
    assert len(exported) == FMI2_EXPORTS and all(e.startswith("fmi2") for e in exported), exported
    dynamic = subprocess.run([readelf, "-d", str(so)], capture_output=True, text=True, check=True).stdout
    assert set(re.findall(r"\(NEEDED\).*\[(\S+)\]", dynamic)) <= {"libc.so.6", "libm.so.6"}
    machine = subprocess.run([readelf, "-h", str(so)], capture_output=True, text=True, check=True).stdout
    assert ("AArch64" if folder == "aarch64-linux" else "X86-64") in machine


def _exports(nm: str, so: Path) -> list[str]:
    defined = subprocess.run([nm, "-D", "--defined-only", str(so)], capture_output=True, text=True, check=True).stdout
    return [line.split()[-1] for line in defined.splitlines() if line.strip()]


def test_the_dll_is_reproducible_from_its_sources(unpacked, tmp_path):
    """The win64 link has no timestamp: sources/ compiled again with the builder's toolchain gives the shipped DLL
    byte for byte (linux64's .so likewise)."""
    from tiltload.native_fmu.compile import NativeSources, compile_shared

    name = "TiltloadSensors"
    for folder in ("win64", "linux64"):
        shipped = _shipped(unpacked, name, folder)
        t = cc.toolchain(folder)
        again = tmp_path / folder / shipped.name
        again.parent.mkdir()
        sources = tmp_path / f"sources_{folder}"
        shutil.copytree(unpacked[name] / "sources", sources)
        assert compile_shared(NativeSources([]), sources, again, t) == []
        assert again.read_bytes() == shipped.read_bytes(), folder


# ---- the same results on every platform ---------------------------------------------------------------
@pytest.mark.parametrize("folder", ["win64", "aarch64-linux"])
@pytest.mark.parametrize("name", FMUS)
@pytest.mark.slow
def test_two_seconds_alone_equal_linux64(unpacked, hosts, tmp_path, name, folder):
    """The default experiment's step for 2 s, every Real output at every step: within 1e-12 of linux64's binary.
    (aarch64 is bit-identical: contraction is off in the sources; win64 differs in libm's last bits.)"""
    _shipped(unpacked, name, folder)
    other = hosts(folder)
    linux = hosts("linux64").run(single_plan(unpacked[name], LINUX64, tmp_path))
    there = other.run(single_plan(unpacked[name], other.platform, tmp_path))
    assert len(linux.values) > 100
    assert there.max_difference(linux) <= SAME


@pytest.mark.slow
def test_the_closed_loop_on_win64_gives_linux_ise(unpacked, hosts, tmp_path, all_fmus):
    """Plant, sensors, scenario, controller (ZSE, trajectory 1) stepped by the C host on win64 under wine for 40 s:
    ISE(x..psi) as tiltload's own master on Linux gets them, to the digits `tiltload run` prints."""
    from support.portable import loop_plan
    from tiltload.master.app.loop.thesis import default_system, loop_metrics
    from tiltload.master.engine.run import run_system

    for name in LOOP.values():
        _shipped(unpacked, name, "win64")
    windows = hosts("win64")
    system = default_system(all_fmus["TiltloadPlant"].parent, "zse", 1)
    folders = {inst: unpacked[name] for inst, name in LOOP.items()}
    seconds = 40.0
    plan, tracked = loop_plan(system, folders, LINUX64, tmp_path, seconds, every=25)
    linux = hosts("linux64").run(plan)
    win = windows.run(loop_plan(system, folders, WIN64, tmp_path, seconds, every=25)[0])
    # the C host runs round(40 / 0.012) = 3333 ticks; tiltload would end at the first tick after 40 s: the same ticks
    ours = run_system(system, round(seconds / system.tick) * system.tick, None, loop_metrics(), progress=False)
    assert ours.error is None and ours.ticks == round(seconds / system.tick)
    for axis, vr in tracked.items():
        mine, native, windows_ise = ours.metrics[f"ISE({axis})"], linux.ise["plant", vr], win.ise["plant", vr]
        assert abs(native - mine) <= 1e-12 * mine  # the C host samples the ISE as tiltload's metrics do
        assert f"{windows_ise:.6g}" == f"{mine:.6g}", axis  # `tiltload run` prints 6 digits
        assert abs(windows_ise - native) <= 1e-12 * native, axis
    assert win.max_difference(linux) <= 1e-11  # plant and controller outputs, every 0.3 s (E_total is near 300 J)


# ---- sources/ build anywhere -----------------------------------------------------------------------------
# `cc -shared *.c` with only what a platform needs: the sources pin the arithmetic and hide their internals
PLAIN = {"gcc": ("gcc", "-std=c99", "-pedantic", "-Wall", "-Wextra", "-O2", "-fPIC"),
         "clang": ("clang", "-std=c99", "-pedantic", "-Wall", "-Wextra", "-O2", "-fPIC")}


@pytest.fixture(scope="module")
def plain(unpacked, tmp_path_factory):
    """plain(compiler, name) -> (the FMU's sources/ built with PLAIN[compiler] only, what the compiler said), built
    once (the files in parallel, as `cc *.c` would one after another)."""
    from concurrent.futures import ThreadPoolExecutor

    out = tmp_path_factory.mktemp("plain")
    made = {}

    def get(compiler: str, name: str) -> tuple[Path, str]:
        if (compiler, name) not in made:
            need(compiler, {"gcc": "gcc", "clang": "clang"}[compiler])
            src, folder = unpacked[name] / "sources", out / f"{compiler}_{name}"
            folder.mkdir()
            files = sorted(src.glob("*.c"))
            with ThreadPoolExecutor(max_workers=os.cpu_count() or 1) as pool:
                said = list(pool.map(lambda f: subprocess.run([*PLAIN[compiler], "-c", str(f), "-o", str(folder / f"{f.stem}.o")],
                                                              capture_output=True, text=True), files))
            library = folder / f"{name}.so"
            link = subprocess.run([PLAIN[compiler][0], "-shared", "-o", str(library), *map(str, sorted(folder.glob("*.o"))), "-lm"],
                                  capture_output=True, text=True)
            assert all(p.returncode == 0 for p in (*said, link)), "".join(p.stderr for p in (*said, link))
            made[compiler, name] = library, "".join(p.stderr for p in (*said, link))
        return made[compiler, name]
    return get


@pytest.mark.parametrize("compiler", sorted(PLAIN))
@pytest.mark.parametrize("name", FMUS)
@pytest.mark.slow
def test_sources_build_warning_free_with_plain_flags_and_give_the_shipped_results(unpacked, hosts, plain, tmp_path, name,
                                                                                  compiler):
    """sources/ of each FMU with gcc or clang at -std=c99 -pedantic -Wall -Wextra and no other flag: zero warnings,
    only the fmi2 functions exported (no -fvisibility, no export map), the shipped linux64 results to the bit."""
    own, said = plain(compiler, name)
    assert said == ""
    exported = _exports(need("nm", "binutils"), own)
    assert len(exported) == FMI2_EXPORTS and all(e.startswith("fmi2") for e in exported), exported
    host = hosts("linux64")
    shipped = host.run(single_plan(unpacked[name], LINUX64, tmp_path))
    rebuilt = host.run(single_plan(unpacked[name], LINUX64, tmp_path, library=own, tag=compiler))
    assert rebuilt.values == shipped.values


def test_source_built_fmus_share_one_process_in_the_global_symbol_scope(unpacked, hosts, plain, tmp_path, all_fmus):
    """The four loop FMUs built from sources/ without any visibility flag, loaded RTLD_GLOBAL into one process (as
    some importers do): each keeps its own hooks, and 2 s of the loop equal the shipped binaries' run to the bit."""
    from support.portable import loop_plan
    from tiltload.master.app.loop.thesis import default_system

    folders = {inst: unpacked[name] for inst, name in LOOP.items()}
    libraries = {inst: plain("gcc", name)[0] for inst, name in LOOP.items()}
    system = default_system(all_fmus["TiltloadPlant"].parent, "zse", 1)
    host = hosts("linux64")
    shipped = host.run(loop_plan(system, folders, LINUX64, tmp_path, 2.0, every=1)[0])
    shared = host.run(loop_plan(system, folders, LINUX64, tmp_path, 2.0, every=1, libraries=libraries,
                                global_scope=True)[0])
    assert shared.values == shipped.values and shared.ise == shipped.ise


@pytest.mark.slow
def test_fmpy_compile_on_an_aarch64_board_gives_the_shipped_aarch64_binary(unpacked, hosts, tmp_path):
    """What docs/platforms.md tells an FMPy user on aarch64 Linux (FMPy looks in binaries/linux64 there): `fmpy
    compile`, i.e. FMPy's own CMake build of sources/ with its default flags. Done here with the aarch64 cross compiler,
    run under qemu: the UAV-alone controller (whose estimator amplified any contraction) equals the shipped
    aarch64-linux binary to the bit."""
    from fmpy.build import build_platform_binary

    name = "TiltrotorController"
    _shipped(unpacked, name, "aarch64-linux")
    need("cmake", "cmake")
    need_platform(AARCH64)
    board, cmake = tmp_path / "board", tmp_path / "cmake"
    shutil.copytree(unpacked[name], board)
    cmake.mkdir()
    build_platform_binary(board, cmake, cmake_options={
        "CMAKE_C_COMPILER:FILEPATH": shutil.which("aarch64-linux-gnu-gcc"), "CMAKE_SYSTEM_NAME:STRING": "Linux",
        "CMAKE_SYSTEM_PROCESSOR:STRING": "aarch64"})
    fmpy_built = board / "binaries" / "linux64" / f"{name}.so"  # FMPy's folder on aarch64 Linux (fmpy.platform)
    assert "AArch64" in subprocess.run(["readelf", "-h", str(fmpy_built)], capture_output=True, text=True).stdout
    host = hosts("aarch64-linux")
    shipped = host.run(single_plan(unpacked[name], AARCH64, tmp_path))
    rebuilt = host.run(single_plan(unpacked[name], AARCH64, tmp_path, library=fmpy_built, tag="fmpy"))
    assert rebuilt.values == shipped.values


# ---- FMI 3.0: the same toolchains, binaries under FMI 3.0's platform tuples --------------------------------------
FMI3_LOOP = ("TiltloadPlant", "TiltloadSensors", "TiltloadScenario", "TiltloadController", "TiltloadSensorsClocked",
             "TiltloadControllerClocked")


@pytest.fixture(scope="module")
def fmi3_fmus() -> dict[str, Path]:
    """The loop's FMI 3.0 FMUs (plain and clocked) in fmus/fmi3/, with every platform whose compiler is here."""
    from tiltload.master.app.loop.fmus import build_many, clocked_recipes, fmu_folder, loop_recipes

    results = build_many([*loop_recipes(("load",)), *clocked_recipes(("load",))], fmu_folder(ROOT / "fmus", 3),
                         progress=lambda *_: None, fmi_version=3)
    return {r.path.stem: r.path for r in results}


@pytest.mark.parametrize("name", FMI3_LOOP)
def test_fmi3_fmus_ship_every_platforms_binary_under_its_tuple_exporting_fmi3_only(fmi3_fmus, tmp_path, name):
    built = [t for t in cc.TOOLCHAINS if cc.find_compiler(t)]
    model = name.removesuffix("Clocked")
    with zipfile.ZipFile(fmi3_fmus[name]) as z:
        binaries = sorted(n for n in z.namelist() if n.startswith("binaries/"))
        info = json.loads(z.read("resources/build_info.json"))
        z.extractall(tmp_path)
    assert binaries == sorted(f"binaries/{t.name}/{model}{t.suffix}" for t in built)  # x86_64-linux, x86_64-windows, ...
    assert info["platforms"] == [t.name for t in built] and info["warnings"] == [] and info["fmi_version"] == 3
    assert validate_fmu(str(fmi3_fmus[name])) == []
    linux = _exports(need("nm", "binutils"), tmp_path / "binaries" / "x86_64-linux" / f"{model}.so")
    assert len(linux) > 70 and all(e.startswith("fmi3") for e in linux)  # every fmi3 function, stubs included
    for t in built:
        path = tmp_path / "binaries" / t.name / f"{model}{t.suffix}"
        if t.suffix == ".dll":
            text = subprocess.run([need("x86_64-w64-mingw32-objdump", "binutils-mingw-w64-x86-64"), "-p", str(path)],
                                  capture_output=True, text=True, check=True).stdout
            exported = re.findall(r"\]\s+(\S+)", text.split("[Ordinal/Name Pointer] Table", 1)[1].split("\n\n", 1)[0])
            assert {m.lower() for m in re.findall(r"DLL Name:\s+(\S+)", text)} <= WINDOWS_DLLS
        else:
            exported = _exports(need(f"{t.compiler.removesuffix('gcc')}nm" if t.name != "x86_64-linux" else "nm", "binutils"), path)
        assert sorted(exported) == sorted(linux), t.name


@pytest.mark.slow
def test_fmi3_clocked_sensors_and_scenario_on_aarch64_and_win64_equal_x86_64(fmi3_fmus, tmp_path):
    """The FMI 3.0 C host (hosts/fmi3_loop_host.c, written from the standard's call sequences) built for each platform
    runs the scenario and the clocked sensors (Event Mode at each group's clock ticks) for 1.2 s: the aarch64 binaries
    under qemu-user give x86_64's every value to the bit (contraction off in the sources), the win64 DLLs under wine
    within 1e-12 (Windows' libm)."""
    from support.fmi3_plan import host_plan
    from support.portable import AARCH64, WIN64, native_path
    from tiltload.master.engine.system import Instance, System
    from tiltload.native_fmu.package import fmi_header_dir
    from tiltload.sensor_fmu.fmu_variables import channel_names
    from tiltload.sensor_fmu.suite import GROUPS

    system = System(0.012, [Instance("scenario", fmi3_fmus["TiltloadScenario"], parameters={"trajectory": 2}, timing="sample"),
                            Instance("sensors", fmi3_fmus["TiltloadSensorsClocked"], parameters={"seed": 5}, timing="sample")],
                    auto_connect=False)
    record = [("scenario", "x_ref"), ("scenario", "z_ref")] + [("sensors", n) for g in GROUPS for n in channel_names(g)]
    ticks = round(1.2 / system.tick)
    prefix = tmp_path / "wineprefix"
    runs = {}
    for platform, p in (("x86_64-linux", LINUX64), ("aarch64-linux", AARCH64), ("x86_64-windows", WIN64)):
        need_platform(p)
        folder = tmp_path / platform
        folder.mkdir()
        plan = host_plan(system, folder, ticks, record, platform, native_path=lambda q, p=p: native_path(q, p))
        host = folder / ("host.exe" if p is WIN64 else "host")
        subprocess.run([p.compiler, "-std=c11", "-Wall", "-Wextra", "-Werror", f"-I{fmi_header_dir(3)}",
                        str(ROOT / "tests" / "support" / "hosts" / "fmi3_loop_host.c"), "-o", str(host), *p.host_flags],
                       check=True)
        proc = subprocess.run([*p.runner, str(host), native_path(plan, p)], capture_output=True, text=True, timeout=600,
                              env=wine_environment(prefix) if p is WIN64 else None)
        assert proc.returncode == 0, proc.stdout[-1000:] + proc.stderr[-2000:]
        runs[platform] = np.array([float.fromhex(line.split()[3]) for line in proc.stdout.splitlines()
                                   if line.split()[0].isdigit()])
    if shutil.which("wineserver"):
        subprocess.run(["wineserver", "-k"], env=wine_environment(prefix), capture_output=True, timeout=60)
    x86 = runs["x86_64-linux"]
    assert len(x86) == ticks * len(record) and np.isfinite(x86).all() and np.ptp(x86) > 0.1
    assert runs["aarch64-linux"].tobytes() == x86.tobytes()
    np.testing.assert_allclose(runs["x86_64-windows"], x86, rtol=SAME, atol=SAME)

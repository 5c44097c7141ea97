"""`tiltload bundle`: the archive a user of another FMI tool gets. Every FMU in it passes FMPy's validation, carries a
binary of the right machine for each of the three platforms (read from the binaries' own headers), and its SSP
packages run; bad output paths and a missing cross compiler are one line and exit 2."""

from __future__ import annotations

import os
import shutil
import struct
import zipfile
from pathlib import Path

import pytest
from support import ROOT
from tiltload.master.app.cli import main

# FMI 2.0 folder / FMI 3.0 tuple -> what the binary's header must say (ELF e_machine, or a PE's machine field)
MACHINES = {"linux64": ("ELF", 0x3E), "x86_64-linux": ("ELF", 0x3E), "aarch64-linux": ("ELF", 0xB7),
            "win64": ("PE", 0x8664), "x86_64-windows": ("PE", 0x8664)}
FMI2 = {"linux64", "win64", "aarch64-linux"}
FMI3 = {"x86_64-linux", "x86_64-windows", "aarch64-linux"}


def machine_of(binary: bytes) -> tuple[str, int]:
    """The machine a shared library is for, from its header (ELF: e_machine at 18; PE: the COFF header's machine)."""
    if binary[:4] == b"\x7fELF":
        return "ELF", struct.unpack_from("<H", binary, 18)[0]
    if binary[:2] == b"MZ":
        pe = struct.unpack_from("<I", binary, 0x3C)[0]
        assert binary[pe:pe + 4] == b"PE\0\0"
        return "PE", struct.unpack_from("<H", binary, pe + 4)[0]
    raise AssertionError("neither ELF nor PE")


@pytest.fixture(scope="module")
def bundle(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("bundle") / "tiltload-fmus.zip"
    assert main(["bundle", str(out), "--fmus", str(ROOT / "fmus")]) == 0
    return out


@pytest.fixture(scope="module")
def opened(bundle, tmp_path_factory) -> Path:
    where = tmp_path_factory.mktemp("opened")
    with zipfile.ZipFile(bundle) as z:
        z.extractall(where)
    return where


@pytest.mark.slow
def test_every_fmu_of_tiltload_build_is_in_it_as_fmi2_and_fmi3(opened):
    from tiltload.master.app.loop.fmus import every_recipe

    assert {p.name for p in (opened / "fmi2").glob("*.fmu")} == {r.fmu_name for r in every_recipe(2)}
    assert {p.name for p in (opened / "fmi3").glob("*.fmu")} == {r.fmu_name for r in every_recipe(3)}
    assert len(list(opened.glob("fmi3/*Clocked.fmu"))) == 4
    assert {p.name for p in opened.glob("fmi3/*SE.fmu")} == {"TiltloadControllerSE.fmu", "TiltrotorControllerSE.fmu"}
    assert {p.name for p in (opened / "ssp").iterdir()} == {"loop.ssp", "loop-fmi3.ssp"}


def test_fmpy_validates_every_fmu_with_no_problem(opened):
    from fmpy.validation import validate_fmu

    fmus = sorted(opened.glob("fmi*/*.fmu"))
    assert len(fmus) == 24  # 9 FMI 2.0; 15 FMI 3.0: the same 9, 4 with clocks, 2 Scheduled Execution
    for fmu in fmus:
        assert validate_fmu(str(fmu)) == [], fmu


def test_every_fmu_has_a_binary_of_the_right_machine_for_each_platform(opened):
    for version, platforms in ((2, FMI2), (3, FMI3)):
        for fmu in sorted((opened / f"fmi{version}").glob("*.fmu")):
            with zipfile.ZipFile(fmu) as z:
                binaries = [n for n in z.namelist() if n.startswith("binaries/") and not n.endswith("/")]
                assert {n.split("/")[1] for n in binaries} == platforms, fmu
                for name in binaries:
                    folder = name.split("/")[1]
                    assert machine_of(z.read(name)) == MACHINES[folder], (fmu.name, name)
                    assert name.endswith(".dll" if "win" in folder else ".so"), name


def test_its_ssp_packages_run_in_tiltload(opened, tmp_path, capsys):
    for package, version in (("loop.ssp", "1.0"), ("loop-fmi3.ssp", "2.0")):
        path = opened / "ssp" / package
        with zipfile.ZipFile(path) as z:
            ssd = z.read("SystemStructure.ssd").decode()
        assert f'version="{version}"' in ssd, package
        code = main(["run", "--system", str(path), "--stop-time", "0.6", "--quiet", "--no-plots", "--out", str(tmp_path),
                     "--name", package.replace(".", "_")])
        assert code == 0, capsys.readouterr().err
        assert (tmp_path / f"{package.replace('.', '_')}.mcap").is_file()


def test_its_readme_lists_every_member_and_ports_txt_holds_the_contract(bundle):
    with zipfile.ZipFile(bundle) as z:
        members = [n for n in z.namelist() if n not in ("README.txt", "PORTS.txt")]
        readme, ports = z.read("README.txt").decode(), z.read("PORTS.txt").decode()
    for member in members:
        folder, name = member.split("/")
        assert f"\n{folder}/ " in readme and f"  {name} " in readme, member
    for output in ("f_R", "f_L", "tau_R", "tau_L"):
        assert output in ports
    assert "controller -> plant (4): f_R f_L tau_R tau_L" in ports
    assert "loop_delay_ticks" in ports and "12 ms" in ports


def _one_error_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    return err[0]


def test_an_existing_output_is_refused_and_left_as_it_was(tmp_path, capsys):
    out = tmp_path / "b.zip"
    out.write_text("keep me")
    assert main(["bundle", str(out)]) == 2
    assert "exists" in _one_error_line(capsys)
    assert out.read_text() == "keep me"


def test_an_output_under_a_file_is_refused(tmp_path, capsys):
    (tmp_path / "file").write_text("")
    with pytest.raises(SystemExit) as exit_:  # refused by OUT's type, as argparse refuses
        main(["bundle", str(tmp_path / "file" / "b.zip")])
    assert exit_.value.code == 2
    assert "is a file, so no file can be made under it" in _one_error_line(capsys)


def test_an_unwritable_folder_is_refused(tmp_path, capsys):
    if os.geteuid() == 0:  # root writes into any folder a mode protects: a file system that takes no file, then
        folder = Path("/proc")
    else:
        folder = tmp_path / "ro"
        folder.mkdir()
        folder.chmod(0o500)
    try:
        assert main(["bundle", str(folder / "b.zip")]) == 2
        line = _one_error_line(capsys)
        assert line.startswith(f"tiltload: error: bundle: cannot write in {folder}:"), line
    finally:
        if folder != Path("/proc"):
            folder.chmod(0o700)


def test_a_missing_cross_compiler_is_named_with_its_package(tmp_path, monkeypatch, capsys):
    only_cc = tmp_path / "bin"
    only_cc.mkdir()
    os.symlink(shutil.which("cc") or shutil.which("gcc"), only_cc / "cc")
    monkeypatch.setenv("PATH", str(only_cc))
    monkeypatch.delenv("CC", raising=False)
    out = tmp_path / "b.zip"
    assert main(["bundle", str(out)]) == 2
    line = _one_error_line(capsys)
    assert "x86_64-w64-mingw32-gcc" in line and "aarch64-linux-gnu-gcc" in line
    assert "apt-get install gcc-mingw-w64-x86-64 gcc-aarch64-linux-gnu" in line
    assert not out.exists()

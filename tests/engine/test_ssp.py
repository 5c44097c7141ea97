"""SSP 1.0 packages: schema-valid, run unmodified by libcosim, Ecos and tiltload, which agree."""

from __future__ import annotations

import io
import zipfile
from pathlib import Path

import numpy as np
import pytest
from support.at_once import at_once
from support.system_libraries import needs_library
from tiltload.controller_fmu.design.cache import cache_root
from tiltload.master.app.cli import main
from tiltload.master.app.loop.thesis import default_system, loop_metrics
from tiltload.master.engine import jacobi
from tiltload.master.engine.errors import DescriptionError
from tiltload.master.engine.execution import Execution
from tiltload.master.engine.fmi.model_description import read_fmu
from tiltload.master.engine.run import run_system
from tiltload.master.engine.ssp import zip_unpack
from tiltload.master.engine.ssp.load import load
from tiltload.master.engine.ssp.schema import PARAMETER_SET, schema_errors
from tiltload.scenario_fmu.trajectories import circle

UNPACK = cache_root() / "ssp"  # where packages are unpacked, as tiltload run does


TICK = 0.012


TICKS = 3333  # 40 s of trajectory 1, a whole number of ticks for every master
ECOS = needs_library("libtbb.so.12")  # ecospy loads it at import


def _export(fmus: Path, out: Path, scenario: str, controller: str, schedule: str, *extra: str) -> Path:
    code = main(["ssp", "export", str(out), "--fmus", str(fmus), "--scenario", scenario, "--controller", controller,
                 "--stop-time", repr(TICKS * TICK), "--schedule", schedule, *extra])
    assert code == 0
    return out


@pytest.fixture(scope="module")
def packages(pipeline_fmus, tmp_path_factory):
    fmus = pipeline_fmus["TiltloadPlant"].parent
    folder = tmp_path_factory.mktemp("ssp")
    return {(scenario, schedule): _export(fmus, folder / f"{scenario}_{schedule}.ssp", scenario, "mixed", schedule)
            for scenario in ("fsi", "zse") for schedule in ("jacobi", "ordered")}


def _ours(package: Path, ticks: int = TICKS) -> np.ndarray:
    system, _, schedule = load(package, UNPACK)
    mds = {i.name: read_fmu(i.fmu, i.name) for i in system.instances}
    if schedule == "jacobi":
        system = jacobi.explicit(system, mds, jacobi=True)
    ex = Execution(system)
    try:
        ex.instantiate()
        ex.run(ticks * TICK)
        plant = ex.instances["plant"]
        return np.array(plant.slave.getReal([plant.vars[n].valueReference for n in ("x", "y", "z")]))
    finally:
        ex.close()


def _libcosim(package: Path, ticks: int = TICKS) -> np.ndarray | None:
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver

    log_output_level(CosimLogLevel.ERROR)
    ex = CosimExecution.from_ssp_file(str(package))
    observer = CosimObserver.create_last_value()
    ex.add_observer(observer)
    if not ex.simulate_until(int(round(ticks * TICK * 1e9))):
        return None
    index = {s.name.decode(): s.index for s in ex.slave_infos()}["plant"]
    refs = {v.name.decode(): v.reference for v in ex.slave_variables(index)}
    return np.array([observer.last_real_values(index, [refs[n]])[0] for n in ("x", "y", "z")])


def _ecos(package: Path, scratch: Path, ticks: int = TICKS) -> np.ndarray:
    """Ecos unpacks the package into $TMPDIR (ecos_ssp_*) and leaves it there: here it unpacks into scratch, and the
    folder is removed after the run."""
    import os
    import shutil

    from ecospy import EcosSimulation

    scratch.mkdir(exist_ok=True)
    before = os.environ.get("TMPDIR")
    os.environ["TMPDIR"] = str(scratch)  # read by the C++ library when it makes its folder
    try:
        sim = EcosSimulation(ssp_path=str(package), step_size=TICK)
        try:
            sim.init(parameter_set=PARAMETER_SET)
            sim.step(ticks)
            return np.array([sim.get_real(f"plant::{n}") for n in ("x", "y", "z")])
        finally:
            sim.terminate()
            sim.free()
    finally:
        if before is None:
            os.environ.pop("TMPDIR")
        else:
            os.environ["TMPDIR"] = before
        for folder in scratch.glob("ecos_ssp_*"):
            shutil.rmtree(folder)


def test_the_package_validates_against_the_ssp_schema(packages):
    with zipfile.ZipFile(packages["zse", "jacobi"]) as z:
        names = set(z.namelist())
        assert {"SystemStructure.ssd", "resources/TiltloadPlant.fmu", "resources/TiltloadController.fmu",
                "resources/TiltloadSensors.fmu", "resources/TiltloadScenario.fmu", "resources/controller.ssv"} <= names
        ssd = z.read("SystemStructure.ssd")
        assert schema_errors(ssd, "ssd") == []
        assert schema_errors(z.read("resources/controller.ssv"), "ssv") == []
    # the check can fail: a connection without its end connector is refused by the schema
    broken = ssd.replace(b'endConnector="f_R"', b"", 1)
    assert broken != ssd and schema_errors(broken, "ssd")
    from lxml import etree

    root = etree.fromstring(ssd)
    ns = {"ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription", "ssc": "http://ssp-standard.org/SSP1/SystemStructureCommon"}
    assert len(root.findall(".//ssd:Connection", ns)) == 92  # every connection written out
    units = {c.get("name"): c.find("ssc:Real", ns).get("unit") for c in root.iterfind(".//ssd:Component[@name='plant']//ssd:Connector", ns)
             if c.find("ssc:Real", ns) is not None}
    assert units["x"] == "m" and units["f_R"] == "N" and units["tau_R"] == "N.m"
    assert float(root.find("ssd:DefaultExperiment", ns).get("stopTime")) == pytest.approx(TICKS * TICK)


@ECOS
@pytest.mark.parametrize("scenario", ["fsi", "zse"])
@pytest.mark.slow
def test_three_masters_run_one_package_and_agree(packages, scenario, tmp_path):
    """d = 2 (the Jacobi export): ours, libcosim and Ecos all stable, final load positions within 1 cm."""
    package = packages[scenario, "jacobi"]
    system, _, _ = load(package, UNPACK)
    assert system.instance("controller").parameters["loop_delay_ticks"] == 2
    ours, theirs, ecos = _ours(package), _libcosim(package), _ecos(package, tmp_path / "ecos")
    assert theirs is not None
    t = TICKS * TICK
    end = np.array([float(v) for v in circle(t)[:3]])  # where the reference is at the end
    for final in (ours, theirs, ecos):
        assert np.isfinite(final).all() and np.linalg.norm(final - end) < 0.25  # on the path: FSI 3 mm, ZSE 10 cm
    assert np.abs(ours - theirs).max() < 0.01 and np.abs(ours - ecos).max() < 0.01
    assert np.abs(theirs - ecos).max() < 1e-9  # in fact the same arithmetic: measured 3e-13 m


@ECOS
@pytest.mark.slow
def test_the_uav_alone_runs_in_the_three_masters_too(pipeline_fmus, tmp_path):
    """Appendix A's loop (DLQR + ZSE, 80 s circle) exported for a Jacobi master: the three agree."""
    from tiltload.master.app.loop.fmus import build_all

    fmus = pipeline_fmus["TiltloadPlant"].parent
    build_all(fmus, vehicles=("uav",))
    ticks = 6666
    package = tmp_path / "uav.ssp"
    assert main(["ssp", "export", str(package), "--fmus", str(fmus), "--vehicle", "uav", "--stop-time", repr(ticks * TICK)]) == 0
    ours, theirs, ecos = _ours(package, ticks), _libcosim(package, ticks), _ecos(package, tmp_path / "ecos", ticks)
    assert theirs is not None and np.linalg.norm(ours - np.array([4.0, 0.0, 1.0])) < 0.1  # back at the circle's start
    assert np.abs(ours - theirs).max() < 0.01 and np.abs(ours - ecos).max() < 0.01


def test_the_plain_design_diverges_in_a_jacobi_master(pipeline_fmus, tmp_path):
    """The thesis's mixed design, made for no delay, in libcosim: the 2 ticks a Jacobi master adds destabilize it."""
    fmus = pipeline_fmus["TiltloadPlant"].parent
    package = _export(fmus, tmp_path / "plain.ssp", "zse", "mixed", "jacobi", "--set", "controller.loop_delay_ticks=0")
    final = _libcosim(package, round(10.0 / TICK))
    assert final is None or not np.all(np.abs(final) < 100.0)


def test_ordered_package_reproduces_tiltload_run_exactly(pipeline_fmus, packages):
    """d = 0: our master on the package gives the metrics of the loop it was exported from, bit for bit."""
    fmus = pipeline_fmus["TiltloadPlant"].parent
    system, stop, schedule = load(packages["zse", "ordered"], UNPACK)
    assert schedule == "ordered" and system.instance("controller").parameters["loop_delay_ticks"] == 0
    assert stop == pytest.approx(TICKS * TICK)
    # what the loop's instances' outputs belong to, and what its plant's request to end is, survive the export
    assert [i.timing for i in system.instances] == [i.timing for i in default_system(fmus, "zse", 1, "mixed").instances]
    assert system.fmu_end == "error"
    ran = [run_system(s, stop, None, loop_metrics(), progress=False).metrics
           for s in (system, default_system(fmus, "zse", 1, "mixed"))]
    assert ran[0] == ran[1]


def test_run_system_ssp_from_the_command_line(packages, tmp_path, capsys):
    code = main(["run", "--system", str(packages["fsi", "jacobi"]), "--stop-time", "2", "--quiet", "--no-plots",
                 "--out", str(tmp_path)])
    out = capsys.readouterr().out
    assert code == 0 and "schedule: jacobi" in out and (tmp_path / "fsi_jacobi_t2s.mcap").is_file()


def test_export_is_reproducible(pipeline_fmus, packages, tmp_path):
    fmus = pipeline_fmus["TiltloadPlant"].parent
    again = _export(fmus, tmp_path / "again.ssp", "zse", "mixed", "jacobi")
    assert again.read_bytes() == packages["zse", "jacobi"].read_bytes()


def _rewrite(package: Path, out: Path, member: str, edit) -> Path:
    with zipfile.ZipFile(package) as src, zipfile.ZipFile(out, "w") as dst:
        for item in src.infolist():
            data = src.read(item.filename)
            if item.filename == member:
                data = edit(data)
                if data is None:
                    continue
            dst.writestr(item, data)
    return out


@pytest.mark.parametrize("label, member, edit, needle", [
    ("no ssd", "SystemStructure.ssd", lambda d: None, "no SystemStructure.ssd"),
    ("ssd not xml", "SystemStructure.ssd", lambda d: b"<ssd:Sys", "does not validate"),
    ("schema violation", "SystemStructure.ssd", lambda d: d.replace(b'name="plant"', b"", 1), "does not validate"),
    ("missing ssv", "resources/plant.ssv", lambda d: None, "is not in the package"),
    ("bad ssv value", "resources/sensors.ssv", lambda d: d.replace(b'<ssv:Integer value="1"/>', b'<ssv:Integer value="x"/>'),
     "sensors.ssv"),
    ("missing fmu", "resources/TiltloadPlant.fmu", lambda d: None, "no such file"),
    ("unknown delay", "SystemStructure.ssd",
     lambda d: d.replace(b"</tl:Master>", b'<tl:Delay source="a.b" target="c.d" ticks="1"/></tl:Master>'), "a.b -> c.d"),
])
def test_a_broken_package_is_one_line_and_exit_2(packages, tmp_path, capsys, label, member, edit, needle):
    bad = _rewrite(packages["fsi", "ordered"], tmp_path / "bad.ssp", member, edit)
    code = main(["run", "--system", str(bad), "--stop-time", "0.1", "--quiet", "--no-plots", "--out", str(tmp_path)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and needle in err[0], (label, err)


def test_not_a_package(tmp_path):
    (tmp_path / "text.ssp").write_text("hello")
    for path, needle in ((tmp_path / "text.ssp", "not a zip"), (tmp_path / "none.ssp", "does not exist")):
        with pytest.raises(DescriptionError, match=needle):
            load(path, UNPACK)
    empty = tmp_path / "empty.ssp"
    with zipfile.ZipFile(empty, "w") as z:
        z.writestr("readme.txt", io.BytesIO(b"x").getvalue())
    with pytest.raises(DescriptionError, match="no SystemStructure.ssd"):
        load(empty, UNPACK)


def _unpacked_leftovers() -> list[Path]:
    return [p for p in UNPACK.glob("*") if p.name.endswith(".partial")] if UNPACK.exists() else []


def _zip(path: Path, members) -> Path:
    """members: (ZipInfo or name, bytes, compression)."""
    with zipfile.ZipFile(path, "w") as z:
        for info, data, compression in members:
            z.writestr(info, data, compression)
    return path


def test_a_link_in_a_package_is_refused_with_one_line(tmp_path, capsys):
    """A symbolic link, then a file written through it: refused at the link, nothing written anywhere."""
    link = zipfile.ZipInfo("resources/evil")
    link.create_system = 3
    link.external_attr = (0o120777 << 16)  # S_IFLNK
    package = _zip(tmp_path / "link.ssp", [(link, str(tmp_path / "outside").encode(), zipfile.ZIP_STORED),
                                           ("resources/evil/x.fmu", b"data", zipfile.ZIP_STORED)])
    code = main(["run", "--system", str(package), "--quiet", "--no-plots"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "'resources/evil' is a symbolic link" in err[0], err
    assert not (tmp_path / "outside").exists() and not _unpacked_leftovers()


def test_a_zip_bomb_is_refused_before_it_unpacks(tmp_path):
    """20 MiB of zeros in a 20 KiB member: more than the 100-fold expansion a package may have."""
    package = _zip(tmp_path / "bomb.ssp", [("SystemStructure.ssd", b"<x/>", zipfile.ZIP_DEFLATED),
                                           ("resources/zeros.bin", bytes(20 << 20), zipfile.ZIP_DEFLATED)])
    assert package.stat().st_size < 100_000
    with pytest.raises(DescriptionError, match=r"'resources/zeros.bin' expands \d+-fold .* more than the 100-fold"):
        load(package, UNPACK)
    assert not _unpacked_leftovers()


def test_a_member_that_lies_about_its_size_is_refused(tmp_path):
    """The declared size checked before unpacking, the written bytes while unpacking: a member that holds more
    than it declares (a crafted header) stops at its declared size."""
    package = _zip(tmp_path / "liar.ssp", [("SystemStructure.ssd", b"<x/>", zipfile.ZIP_DEFLATED),
                                           ("resources/data.bin", bytes(3 << 20), zipfile.ZIP_DEFLATED)])
    raw = bytearray(package.read_bytes())
    declared = (3 << 20).to_bytes(4, "little")
    assert raw.count(declared) == 2  # in the local header and in the central directory
    raw = raw.replace(declared, (1000).to_bytes(4, "little"))
    liar = tmp_path / "liar2.ssp"
    liar.write_bytes(bytes(raw))
    with pytest.raises(DescriptionError, match="holds more than the 1000 bytes it declares|the archive is damaged"):
        load(liar, UNPACK)
    assert not _unpacked_leftovers()


def test_the_unpacked_total_is_limited(tmp_path, monkeypatch):
    monkeypatch.setattr(zip_unpack, "MAX_UNPACKED", 1 << 20)
    package = _zip(tmp_path / "big.ssp", [("SystemStructure.ssd", b"<x/>", zipfile.ZIP_DEFLATED),
                                          ("resources/a.bin", bytes(700 << 10), zipfile.ZIP_STORED),
                                          ("resources/b.bin", bytes(700 << 10), zipfile.ZIP_STORED)])
    with pytest.raises(DescriptionError, match="unpacks to 1.4 MiB, more than the 1 MiB a package may"):
        load(package, UNPACK)


def test_a_package_is_hashed_without_reading_it_whole(packages, monkeypatch, tmp_path):
    """The unpack folder is named by the package's SHA-256, read in blocks: a 1 GB package never sits in memory."""
    import hashlib
    import tracemalloc

    package = packages["fsi", "ordered"]
    real = Path.read_bytes

    def guarded(self):
        assert self != package, "the package was read whole"
        return real(self)
    monkeypatch.setattr(Path, "read_bytes", guarded)
    load(package, UNPACK)
    big = tmp_path / "big.ssp"
    big.write_bytes(bytes(range(256)) * (1 << 16))  # 16 MiB
    tracemalloc.start()
    digest = zip_unpack.package_digest(big)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert digest == hashlib.sha256(real(big)).hexdigest() and peak < 1 << 20


@pytest.mark.parametrize("where", ["absolute", "up"])
def test_a_component_outside_the_package_is_refused_unless_allowed(packages, pipeline_fmus, tmp_path, capsys, where):
    plant = pipeline_fmus["TiltloadPlant"]
    source = str(plant) if where == "absolute" else "../" * 12 + str(plant).lstrip("/")
    bad = _rewrite(packages["fsi", "ordered"], tmp_path / "outside.ssp", "SystemStructure.ssd",
                   lambda d: d.replace(b'source="resources/TiltloadPlant.fmu"', f'source="{source}"'.encode()))
    args = ["run", "--system", str(bad), "--stop-time", "0.12", "--quiet", "--no-plots", "--out", str(tmp_path)]
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "component plant: its FMU" in err[0] and "lies outside the package" in err[0], err
    assert "--allow-external-fmus" in err[0]
    assert main([*args, "--allow-external-fmus"]) == 0


def test_unpackers_of_one_package_at_once_share_one_whole_folder(tmp_path):
    """Eight threads unpack the same package into an empty folder at once (a leftover of a dead unpacker there
    too): each gets the one published folder, whole, and nothing else is left."""
    package = _zip(tmp_path / "p.ssp", [(f"resources/f{i}.bin", bytes(range(256)) * 64, zipfile.ZIP_DEFLATED)
                                        for i in range(40)])
    into = tmp_path / "unpack"
    (into / zip_unpack.package_digest(package)[:20]).mkdir(parents=True)  # no .complete: left by a crash
    got, errors = at_once(lambda: zip_unpack.unpack(package, into))
    assert errors == [] and len(set(got)) == 1
    folder = got[0]
    assert (folder / ".complete").exists() and len(list((folder / "resources").iterdir())) == 40
    assert [p.name for p in into.iterdir()] == [folder.name]

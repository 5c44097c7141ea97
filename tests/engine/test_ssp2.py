"""SSP 2.0 export of a system with FMI 3.0 FMUs (master/engine/ssp/ssp2.py): valid against the SSP 2.0 schemas (both forms)
and pyssp-standard's check, FMI 3.0 types and clocks declared, FMI 2.0 components kept SSP 1.0-typed, read back by
ssp.load.load into the same system, which runs to the same metrics bit for bit; FMI 2.0-only systems stay SSP 1.0."""

from __future__ import annotations

import zipfile

import pytest
from lxml import etree
from support import T
from tiltload.master.app.loop.thesis import default_system, loop_metrics
from tiltload.master.engine.errors import DescriptionError
from tiltload.master.engine.run import run_system
from tiltload.master.engine.ssp import ssp2
from tiltload.master.engine.ssp.export import export
from tiltload.master.engine.ssp.load import load
from tiltload.master.engine.ssp.schema import SSD_NAME, TL_NS, schema_errors
from tiltload.sensor_fmu.fmu_variables import channel_names
from tiltload.sensor_fmu.suite import GROUPS

NS = {"ssd": ssp2.SSD, "ssc": ssp2.SSC, "ssv": ssp2.SSV, "tl": TL_NS}


@pytest.fixture(scope="module")
def fmi3_set(fmi3_fmus):
    from tiltload.master.app.loop.fmus import build_all

    folder = fmi3_fmus["TiltloadPlant"].parent
    build_all(folder, progress=lambda *_: None, fmi_version=3, clocked=True)
    return folder


@pytest.fixture(scope="module")
def package(fmi3_set, tmp_path_factory):
    system = default_system(fmi3_set, "zse", 1, "mixed", fmi=3, clocked=True)
    return ssp2.export(system, tmp_path_factory.mktemp("ssp2") / "loop3.ssp", 2.4), system


def _connectors(root, component: str) -> dict[str, etree._Element]:
    comp = root.find(f"ssd:System/ssd:Elements/ssd:Component[@name='{component}']", NS)
    return {c.get("name"): c for c in comp.iterfind("ssd:Connectors/ssd:Connector", NS)}


def test_the_package_validates_against_the_ssp_2_0_schemas(package, tmp_path):
    path, _ = package
    with zipfile.ZipFile(path) as z:
        ssd = z.read(SSD_NAME)
        assert schema_errors(ssd, "ssd2") == [] and schema_errors(ssd, "ssd2_11") == []
        for member in (m for m in z.namelist() if m.endswith(".ssv")):
            assert schema_errors(z.read(member), "ssv2") == [], member
        z.extractall(tmp_path)
    assert schema_errors(ssd, "ssd")  # SSP 1.0 has no Float64 or Clock: this is 2.0 only
    from pyssp_standard.ssd import SSD

    with SSD(tmp_path / SSD_NAME) as doc:  # pyssp-standard's own compliance check (the SSP 2.0 XSD 1.1)
        assert doc.version == "2.0"
        doc.__check_compliance__()


def test_fmi3_types_and_clocks_are_declared(package):
    path, _ = package
    with zipfile.ZipFile(path) as z:
        root = etree.fromstring(z.read(SSD_NAME))
    assert root.get("version") == "2.0"
    sensors = _connectors(root, "sensors")
    for g in GROUPS:
        clock = sensors[f"{g.name}_clock"].find("ssc:Clock", NS)
        assert clock.get("intervalVariability") == "constant" and float(clock.get("intervalDecimal")) == g.period
        for n in channel_names(g):
            assert [c.get("name") for c in sensors[n].iterfind("ssd:Clock", NS)] == [f"{g.name}_clock"]
            assert sensors[n].find("ssc:Float64", NS) is not None
    assert sensors["seed"].get("kind") == "parameter" and sensors["seed"].find("ssc:Int32", NS) is not None
    assert sensors["gps_new"].find("ssc:Boolean", NS) is not None and sensors["gps_new"].find("ssd:Clock", NS) is None
    controller = _connectors(root, "controller")
    assert [c.get("name") for c in controller["f_R"].iterfind("ssd:Clock", NS)] == ["control_clock"]
    connected = {c.get("endConnector") for c in root.iterfind("ssd:System/ssd:Connections/ssd:Connection", NS)}
    assert not {n for n in connected if n.endswith("_clock")}  # clocks are ticked by the importer, not connected
    master = root.find("ssd:System/ssd:Annotations/ssc:Annotation/tl:Master", NS)
    assert {e.get("name"): e.get("fmi") for e in master.iterfind("tl:Instance", NS)} == dict.fromkeys(
        ("scenario", "sensors", "controller", "plant"), "3")


def test_read_back_it_is_the_same_system_and_runs_bit_for_bit(package, tmp_path):
    path, system = package
    loaded, stop, schedule = load(path, tmp_path)
    assert stop == 2.4 and schedule == "ordered" and loaded.tick == T
    assert [(i.name, i.fmi, i.timing, i.parameters) for i in loaded.instances] == \
        [(i.name, i.fmi, i.timing, i.parameters) for i in system.instances]
    a = run_system(loaded, stop, None, loop_metrics(), progress=False)
    b = run_system(system, stop, None, loop_metrics(), progress=False)
    assert a.error is None and a.metrics == b.metrics


def test_fmi2_components_keep_their_types_and_fmi2_only_systems_stay_ssp_1_0(fmus, fmi3_set, tmp_path):
    mixed = default_system(fmus, "zse", 1, "mixed")
    mixed.instance("sensors").fmu = fmi3_set / "TiltloadSensorsClocked.fmu"
    path = ssp2.export(mixed, tmp_path / "mixed.ssp", 1.2)
    with zipfile.ZipFile(path) as z:
        root = etree.fromstring(z.read(SSD_NAME))
    assert _connectors(root, "plant")["x"].find("ssc:Real", NS) is not None
    assert _connectors(root, "sensors")["x"].find("ssc:Float64", NS) is not None
    from tiltload.master.engine.fmi.model_description import read_fmu

    fmi2 = default_system(fmus, "zse", 1, "mixed")
    assert not ssp2.needs_ssp2({i.name: read_fmu(i.fmu, i.name) for i in fmi2.instances})
    with zipfile.ZipFile(export(fmi2, tmp_path / "fmi2.ssp", 1.2)) as z:
        assert etree.fromstring(z.read(SSD_NAME)).get("version") == "1.0"


def test_a_broken_ssp_2_0_document_is_refused_naming_the_schema(package, tmp_path):
    path, _ = package
    broken = tmp_path / "broken.ssp"
    with zipfile.ZipFile(path) as src, zipfile.ZipFile(broken, "w") as dst:
        for item in src.infolist():
            data = src.read(item)
            if item.filename == SSD_NAME:
                data = data.replace(b'intervalVariability="constant"', b'intervalVariability="sometimes"', 1)
            dst.writestr(item, data)
    with pytest.raises(DescriptionError, match="does not validate against the SSP 2.0 schema"):
        load(broken, tmp_path / "unpack")


def test_cli_exports_the_fmi3_loop_as_ssp_2_0(fmi3_set, tmp_path, capsys):
    from tiltload.master.app.cli import main

    out = tmp_path / "cli.ssp"
    assert main(["ssp", "export", str(out), "--fmi", "3", "--clocks", "--fmus", str(fmi3_set.parent), "--stop-time", "1.2"]) == 0
    said = capsys.readouterr().out
    assert "SSP 2.0 package, 4 FMUs, 1.2 s, prepared for an ordered master" in said
    assert main(["run", "--system", str(out), "--quiet", "--no-plots", "--out", str(tmp_path / "runs")]) == 0

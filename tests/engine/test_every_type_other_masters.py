"""The every-type FMUs (support/every_type_fmu) in standard SSP packages, with no tiltload annotation, run in libcosim
and in Ecos (issue 64): each master's log equals tiltload's at every time both log, 0 difference for the discrete
values; where a master cannot run a package it says so with its own message, and the test says which.

A package: source -> sink, every output of the source into the sink's input of its type, the source's parameters and
inputs set by an SSV parameter set (the sink keeps its starts: p = 0, so y = u). Three packages per FMI version:
  "every type": tiltload's `ssp export` of that system with its annotations taken out (SSP 1.0 for FMI 2.0, SSP 2.0
    for FMI 3.0; Enumeration connectors and parameters);
  "ssp1 types": written here, SSP 1.0, the connector types SSP 1.0 has but Enumeration (Real, Integer, Boolean; the
    FMI 3.0 FMU's Float64, Int32, Boolean);
  "ssp1 types + Enumeration": the same with the Enumeration connectors and connection.
tiltload runs it as `tiltload run --system` does (the FMUs in this process: --trust-fmus; in a worker process the
log is the same: test_an_isolated_sink_s_sample_at_0_holds_its_connection), step 0.1 s (the FMUs' DefaultExperiment step, given to
libcosim and Ecos too, as no annotation says it).

Measured (Ecos 0.7.2, libcosimpy 0.0.6): every compared value equal, the continuous ones too (largest difference 0),
at t = 0, 0.1, ..., 0.5 s (libcosim's time-series observer holds its reals and integers to 0.4 s: 5 times there).
Sampling: tiltload and Ecos sample an FMU after its step's outputs reached the inputs they feed (a feedthrough output
shows its new input); libcosim samples before: its sink at t_k shows the input it stepped with, tiltload's sink at
t_(k-1). The sink is compared with that shift (the value carried by the connection, exactly); the source, fed by
nothing, without one."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
from lxml import etree
from support import every_type_fmu as et
from support.system_libraries import needs_library
from tiltload.master.app.cli import main
from tiltload.master.engine.log import reader as log_reader

STEP, STEPS = 0.1, 5
RUNNER = Path(et.__file__).parents[1] / "other_masters.py"
SOURCE_VALUES = {"Real": 0.3, "Float64": 0.3, "Integer": -70000, "Int32": -70000, "Boolean": True}  # p_T
SOURCE_INPUTS = {"Real": 1.25, "Float64": 1.25, "Integer": 2**30, "Int32": 2**30, "Boolean": True}  # u_T
SSP1 = {2: {"Real": "Real", "Integer": "Integer", "Boolean": "Boolean"},
        3: {"Float64": "Real", "Int32": "Integer", "Boolean": "Boolean"}}  # FMI type -> SSP 1.0 connector type
KIND = {"Real": "real", "Integer": "integer", "Boolean": "boolean"}
CONTINUOUS = {"Real", "Float64"}
# (master, FMI version, package): the master's own message when it refuses the package (measured; the test checks it)
CANNOT = {("libcosim", 2, "every type"): "Don't know how to handle Enumeration type!",
          ("libcosim", 3, "every type"): "A valid connector type was not found!",
          ("libcosim", 3, "ssp1 types"): "Unsupported FMI version for FMU",
          ("ecos", 2, "every type"): "Unknown XML node in ssv:Parameter encountered!",
          ("ecos", 3, "every type"): "Unsupported SSP version: '2.0'!",
          ("libcosim", 2, "ssp1 types + Enumeration"): "Don't know how to handle Enumeration type!",
          ("libcosim", 3, "ssp1 types + Enumeration"): "Don't know how to handle Enumeration type!",
          ("ecos", 2, "ssp1 types + Enumeration"): "No such real property: source::y_Enumeration",
          ("ecos", 3, "ssp1 types + Enumeration"): "No such real property: source::y_Enumeration"}
ECOS = needs_library("libtbb.so.12")  # ecospy loads it at import


def _without_annotations(exported: Path, out: Path) -> Path:
    with zipfile.ZipFile(exported) as src, zipfile.ZipFile(out, "w") as dst:
        for item in src.infolist():
            data = src.read(item.filename)
            if item.filename == "SystemStructure.ssd":
                root = etree.fromstring(data)
                for annotations in list(root.iter("{*}Annotations")):
                    annotations.getparent().remove(annotations)
                etree.cleanup_namespaces(root)
                data = etree.tostring(root, xml_declaration=True, encoding="utf-8")
                assert b"tiltload.master" not in data and b"Annotation" not in data
            dst.writestr(item, data)
    return out


def _every_type(folder: Path, fmu: Path, version: int) -> Path:
    from test_every_type import INPUT, START

    types = et.FMI3_TYPES if version == 3 else et.FMI2_TYPES
    values = {**{f"p_{t}": START[t] for t in types}, **{f"u_{t}": INPUT[t] for t in types}}
    description = folder / "every.json"
    description.write_text(json.dumps({
        "tick": STEP, "auto_connect": False,
        "instances": [{"name": "source", "fmu": str(fmu), "parameters": values}, {"name": "sink", "fmu": str(fmu)}],
        "connections": [{"source": f"source.y_{t}", "target": f"sink.u_{t}"} for t in types]}))
    assert main(["ssp", "export", str(folder / "exported.ssp"), "--system", str(description), "--stop-time",
                 repr(STEPS * STEP)]) == 0
    return _without_annotations(folder / "exported.ssp", folder / "every_type.ssp")


def _ssp1_types(folder: Path, fmu: Path, version: int, enumeration: bool = False) -> Path:
    """With enumeration, the Enumeration connectors and connection too (SSP 1.0 has them; the source's Enumeration
    keeps its start, so the parameter set holds no Enumeration value)."""
    types = SSP1[version]
    connectors = "".join(f'<ssd:Connector name="{p}_{t}" kind="{kind}"><ssc:{ssc}/></ssd:Connector>'
                         for t, ssc in {**types, **({"Enumeration": 'Enumeration name="Colour"'} if enumeration else {})}
                         .items() for p, kind in (("u", "input"), ("y", "output")))
    enumerations = ('<ssd:Enumerations><ssc:Enumeration name="Colour">' + "".join(
        f'<ssc:Item name="{n}" value="{v}"/>' for n, v in et.ITEMS) + "</ssc:Enumeration></ssd:Enumerations>"
                    if enumeration else "")
    ssd = f"""<?xml version="1.0" encoding="UTF-8"?>
<ssd:SystemStructureDescription xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription"
    xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon" version="1.0" name="ssp1types">
  <ssd:System name="ssp1types">
    <ssd:Elements>
      <ssd:Component name="source" type="application/x-fmu-sharedlibrary" source="resources/{fmu.name}">
        <ssd:Connectors>{connectors}</ssd:Connectors>
        <ssd:ParameterBindings><ssd:ParameterBinding source="resources/source.ssv"/></ssd:ParameterBindings>
      </ssd:Component>
      <ssd:Component name="sink" type="application/x-fmu-sharedlibrary" source="resources/{fmu.name}">
        <ssd:Connectors>{connectors}</ssd:Connectors>
      </ssd:Component>
    </ssd:Elements>
    <ssd:Connections>{"".join(f'<ssd:Connection startElement="source" startConnector="y_{t}" endElement="sink" '
                              f'endConnector="u_{t}"/>' for t in [*types, *(["Enumeration"] if enumeration else [])])}
    </ssd:Connections>
  </ssd:System>
  {enumerations}
  <ssd:DefaultExperiment startTime="0" stopTime="{STEPS * STEP!r}"/>
</ssd:SystemStructureDescription>
"""

    def text(t, x):
        return str(x).lower() if t == "Boolean" else repr(x)
    parameters = "".join(f'<ssv:Parameter name="{p}_{t}"><ssv:{ssc} value="{text(t, table[t])}"/></ssv:Parameter>'
                         for t, ssc in types.items() for p, table in (("p", SOURCE_VALUES), ("u", SOURCE_INPUTS)))
    ssv = ('<?xml version="1.0" encoding="UTF-8"?><ssv:ParameterSet xmlns:ssv="http://ssp-standard.org/SSP1/'
           'SystemStructureParameterValues" version="1.0" name="initialValues"><ssv:Parameters>'
           f"{parameters}</ssv:Parameters></ssv:ParameterSet>")
    from tiltload.master.engine.ssp.schema import schema_errors

    assert schema_errors(ssd.encode(), "ssd") == [] and schema_errors(ssv.encode(), "ssv") == []
    package = folder / f"ssp1_types{'_enumeration' if enumeration else ''}.ssp"
    with zipfile.ZipFile(package, "w") as z:
        z.writestr("SystemStructure.ssd", ssd)
        z.writestr("resources/source.ssv", ssv)
        z.write(fmu, f"resources/{fmu.name}")
    return package


@pytest.fixture(scope="module", params=[2, 3], ids=["fmi2", "fmi3"])
def packages(request, tmp_path_factory):
    version = request.param
    folder = tmp_path_factory.mktemp(f"other{version}")
    fmu = et.every_type_fmu(folder, version)
    return version, {"every type": _every_type(folder, fmu, version), "ssp1 types": _ssp1_types(folder, fmu, version),
                     "ssp1 types + Enumeration": _ssp1_types(folder, fmu, version, enumeration=True)}


def _compared(version: int, package: str) -> list[tuple[str, str, str]]:
    """(instance, variable, kind) of every connected output: the connector types the package has."""
    if package.startswith("ssp1 types"):
        types = {t: KIND[ssc] for t, ssc in SSP1[version].items()}
        if package.endswith("Enumeration"):
            types["Enumeration"] = "integer"
    else:
        types = {t: ("real" if t in CONTINUOUS or t.startswith("Float") else "boolean" if t == "Boolean" else "integer")
                 for t in (et.FMI3_TYPES if version == 3 else et.FMI2_TYPES)}
    return [(i, f"y_{t}", kind) for i in ("source", "sink") for t, kind in types.items()]


def _tiltload(package: Path, out: Path, *extra: str) -> dict[str, list[dict]]:
    assert main(["run", "--system", str(package), "--out", str(out), "--no-plots", "--quiet", *extra]) == 0
    log = log_reader.read(next(out.rglob("*.mcap")))
    return {name: log[f"/{name}"] for name in ("source", "sink")}


def _other(tool: str, package: Path, variables, scratch: Path) -> dict:
    """The master's log ({"instance.variable": [[t, value], ...]}) or {"error": its message}; it unpacks into
    scratch ($TMPDIR), not the machine's /tmp."""
    scratch.mkdir(exist_ok=True)
    done = subprocess.run([sys.executable, str(RUNNER), tool, str(package), repr(STEP), str(STEPS),
                           *(f"{i}.{n}:{k}" for i, n, k in variables)], capture_output=True, text=True, timeout=300,
                          env={**os.environ, "TMPDIR": str(scratch)})
    lines = [line for line in done.stdout.splitlines() if line.startswith("{")]
    if done.returncode == 0 and lines:
        return json.loads(lines[-1])
    said = [line for line in done.stderr.splitlines() if "error" in line.lower()]  # libcosim aborts: its last words
    assert said, f"{tool} ended with {done.returncode} and no message: {done.stderr[-2000:]}"
    return {"error": said[-1]}


@pytest.mark.parametrize("tool", ["libcosim", pytest.param("ecos", marks=ECOS)])
@pytest.mark.parametrize("package", ["every type", "ssp1 types", "ssp1 types + Enumeration"])
def test_a_standard_package_of_every_type_runs_in_libcosim_and_ecos_as_in_tiltload(packages, package, tool, tmp_path):
    version, paths = packages
    variables = _compared(version, package)
    theirs = _other(tool, paths[package], variables, tmp_path / "scratch")
    if "error" in theirs:
        known = CANNOT.get((tool, version, package))
        assert known is not None and known in theirs["error"], (tool, version, package, theirs["error"])
        pytest.xfail(f"{tool} cannot run the FMI {version}.0 package '{package}': {theirs['error']}")
    ours = _tiltload(paths[package], tmp_path / "ours", "--trust-fmus")
    largest, compared = 0.0, {}
    for instance, name, kind in variables:
        mine = {round(m["t"], 9): m[name] for m in ours[instance]}
        shift = STEP if tool == "libcosim" and instance == "sink" else 0.0  # libcosim samples before the transfer
        both = [(value, mine[round(max(t - shift, 0.0), 9)]) for t, value in theirs[f"{instance}.{name}"]
                if round(t, 9) in mine]
        compared[instance, name] = len(both)
        assert len(both) >= STEPS, (instance, name, theirs[f"{instance}.{name}"])  # every time both log: 0 to 0.5 s
        if kind == "real":
            got, want = np.array(both).T
            largest = max(largest, float(np.abs(got - want).max()))
            assert np.allclose(got, want, rtol=0, atol=1e-12), (tool, instance, name, both)
        else:
            assert [bool(a) if kind == "boolean" else int(a) for a, _ in both] == [b for _, b in both], \
                (tool, instance, name, both)
    # the comparison can fail: every output compared moves (the source's each step, the sink's after it)
    assert all(len({m[name] for m in ours[instance]}) > 1 for instance, name, _ in variables)
    print(f"\n{tool}, FMI {version}.0, {package}: {compared} values equal; largest continuous difference {largest:g}")


@pytest.mark.parametrize("version", [2, 3], ids=["fmi2", "fmi3"])
def test_an_isolated_sink_s_sample_at_0_holds_its_connection(version, tmp_path):
    """An FMU in a worker process (tiltload run's default for an FMU built elsewhere) is connected at initialization as
    in this process: its connected inputs travel with the init request and are set in its Initialization Mode, so its
    sample at t = 0 shows the connected value (1.25, as libcosim, Ecos and FMPy give), not its start (0). The whole
    isolated log, String and Binary outputs included, equals the in-process one."""
    fmu = et.every_type_fmu(tmp_path, version)
    package = _ssp1_types(tmp_path, fmu, version)
    isolated, trusted = _tiltload(package, tmp_path / "isolated"), _tiltload(package, tmp_path / "trusted", "--trust-fmus")
    real = "y_Real" if version == 2 else "y_Float64"
    assert trusted["sink"][0]["t"] == isolated["sink"][0]["t"] == 0.0
    assert isolated["sink"][0][real] == trusted["sink"][0][real] == trusted["source"][0][real] == 1.25
    assert isolated["sink"][0]["y_Boolean"] is True and isolated["sink"][0][real.replace("Real", "Integer").replace(
        "Float64", "Int32")] == 2**30  # the source's inputs, through it, not the sink's starts (false, 0)
    assert isolated == trusted

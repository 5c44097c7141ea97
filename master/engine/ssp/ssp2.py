"""SSP 2.0 packages of a system with FMI 3.0 FMUs: what SSP 1.0 (ssp/export.py) cannot say, FMI 3.0 types and clocks.

SSP 2.0 (modelica/ssp-standard, tag v2.0) keeps SSP 1.0's namespaces and adds the FMI 3.0 connector types
(ssc:Float64, ssc:Int32, ..., ssc:Clock) and the association of a connector with a clock (ssd:Clock). pyssp-standard
ships the SSP 2.0 schemas but its object model knows only SSP 1.0's types, so the documents are written here with
lxml and checked against those schemas (the XSD 1.0 form and the XSD 1.1 form pyssp-standard itself uses); nothing
is written that does not validate. An FMU's periodic input clocks are connectors of kind input with their
intervals; they are not connected: the importer ticks each from its own interval. FMI 2.0 components in the same
system keep SSP 1.0's types (Real, Integer). Everything else is as in ssp/export.py: one SSV parameter set per component
(version 2.0), every connection explicit, tiltload's annotation (tick, schedule, timing, the FMI version of each
instance, delays, faults) and libcosim's fixed step. ssp/load.py reads the package back.
"""

from __future__ import annotations

from pathlib import Path

from lxml import etree

from ..errors import DescriptionError
from ..fmi.model_description import FMI2_TYPE, clocks_of, fmi_type, fmi_version, read_fmu
from ..system import Instance, System
from .export import check_members, enumeration_name, enumerations, master_annotation, osp_annotation, ssv_text, write_package
from .schema import FMU_TYPE, OSP_NS, PARAMETER_SET, SSD_NAME, TL_NS, schema_errors

SSD = "http://ssp-standard.org/SSP1/SystemStructureDescription"
SSC = "http://ssp-standard.org/SSP1/SystemStructureCommon"
SSV = "http://ssp-standard.org/SSP1/SystemStructureParameterValues"
NSMAP = {"ssd": SSD, "ssc": SSC, "ssv": SSV, "tl": TL_NS, "osp": OSP_NS}
BASE = ("kg", "m", "s", "A", "K", "mol", "cd", "rad")
_CLOCK_ATTRIBUTES = ("intervalVariability", "intervalDecimal", "shiftDecimal", "supportsFraction", "resolution",
                     "intervalCounter", "shiftCounter")


def needs_ssp2(mds: dict) -> bool:
    """A system with an FMI 3.0 FMU is an SSP 2.0 package; one of FMI 2.0 FMUs only stays SSP 1.0 (libcosim, Ecos)."""
    return any(fmi_version(md) == 3 for md in mds.values())


def _q(ns: str, tag: str) -> str:
    return f"{{{ns}}}{tag}"


def _type_name(md, v) -> str:
    """The connector type SSP names a variable by: FMI 3.0's type, or FMI 2.0's for an FMI 2.0 FMU (SSP 1.0's)."""
    name = fmi_type(v)
    return name if fmi_version(md) == 3 else next(k for k, x in FMI2_TYPE.items() if x == name)


def _clock_elements(fmu: Path) -> dict[str, etree._Element]:
    import zipfile

    with zipfile.ZipFile(fmu) as z:
        root = etree.fromstring(z.read("modelDescription.xml"))
    return {e.get("name"): e for e in root.iter("Clock")}


def _connectors(comp, inst: Instance, md) -> None:
    connectors = etree.SubElement(comp, _q(SSD, "Connectors"))
    declared = _clock_elements(inst.fmu) if clocks_of(md) else {}
    for k in clocks_of(md):
        c = etree.SubElement(connectors, _q(SSD, "Connector"), name=k.name, kind="input")
        etree.SubElement(c, _q(SSC, "Clock"), {a: declared[k.name].get(a) for a in _CLOCK_ATTRIBUTES
                                              if declared[k.name].get(a) is not None})
    clock_names = {k.name for k in clocks_of(md)}
    for v in md.modelVariables:
        if not (v.causality in ("input", "output") or v.name in inst.parameters):
            continue
        kind = v.causality if v.causality in ("input", "output") else "parameter"
        c = etree.SubElement(connectors, _q(SSD, "Connector"), name=v.name, kind=kind)
        unit = v.declaredType.unit if v.unit is None and v.declaredType is not None else v.unit
        typed = etree.SubElement(c, _q(SSC, _type_name(md, v)))
        if fmi_type(v) in ("Float64", "Float32") and unit:
            typed.set("unit", unit)
        if fmi_type(v) == "Enumeration":
            typed.set("name", enumeration_name(v))
        for k in v.clocks or ():
            if k.name in clock_names:
                etree.SubElement(c, _q(SSD, "Clock"), name=k.name)


def _units(root, mds: dict) -> None:
    seen: dict[str, object] = {}
    for md in mds.values():
        declared = {u.name: u.baseUnit for u in md.unitDefinitions}
        for v in md.modelVariables:
            if v.type == "Real" and v.unit and v.unit not in seen:
                seen[v.unit] = declared.get(v.unit)
    if not seen:
        return
    units = etree.SubElement(root, _q(SSD, "Units"))
    for name, base in seen.items():
        unit = etree.SubElement(units, _q(SSC, "Unit"), name=name)
        etree.SubElement(unit, _q(SSC, "BaseUnit"), {k: str(int(getattr(base, k))) for k in BASE
                                                     if base is not None and getattr(base, k)})


def ssd_document(system: System, mds: dict, stop: float, schedule: str = "ordered", name: str = "tiltload") -> bytes:
    """The SystemStructure.ssd (SSP 2.0) of a system whose connections are all explicit (jacobi.explicit)."""
    root = etree.Element(_q(SSD, "SystemStructureDescription"), nsmap=NSMAP, version="2.0", name=name,
                         generationTool="tiltload")
    top = etree.SubElement(root, _q(SSD, "System"), name=name)
    elements = etree.SubElement(top, _q(SSD, "Elements"))
    for inst in system.instances:
        md = mds[inst.name]
        comp = etree.SubElement(elements, _q(SSD, "Component"), name=inst.name, type=FMU_TYPE,
                                source=f"resources/{Path(inst.fmu).name}", implementation="CoSimulation")
        _connectors(comp, inst, md)
        if inst.parameters:
            bindings = etree.SubElement(comp, _q(SSD, "ParameterBindings"))
            etree.SubElement(bindings, _q(SSD, "ParameterBinding"), source=f"resources/{inst.name}.ssv")
    if system.connections:
        connections = etree.SubElement(top, _q(SSD, "Connections"))
        for c in system.connections:
            (se, sc), (ee, ec) = c.source.split(".", 1), c.target.split(".", 1)
            etree.SubElement(connections, _q(SSD, "Connection"), startElement=se, startConnector=sc, endElement=ee,
                             endConnector=ec)
    notes = etree.SubElement(top, _q(SSD, "Annotations"))
    notes.append(master_annotation(system, schedule, [c for c in system.connections if c.delay]).root)
    listed = {(inst.name, name) for inst in system.instances for name in inst.parameters}
    enums = enumerations(SSD, SSC, mds, lambda name, v: v.causality in ("input", "output") or (name, v.name) in listed)
    if enums is not None:
        root.append(enums)
    _units(root, mds)
    experiment = etree.SubElement(root, _q(SSD, "DefaultExperiment"), startTime=repr(float(system.start_time)), stopTime=repr(float(stop)))
    etree.SubElement(experiment, _q(SSD, "Annotations")).append(osp_annotation(system.tick).root)
    etree.cleanup_namespaces(root, top_nsmap=NSMAP)
    return etree.tostring(root, pretty_print=True, xml_declaration=True, encoding="utf-8")


def ssv_document(inst: Instance, md) -> bytes:
    """The instance's parameter values as an SSV 2.0 parameter set, typed as the FMU declares them."""
    from ..fmi.model_description import checked_value

    variables = {v.name: v for v in md.modelVariables}
    root = etree.Element(_q(SSV, "ParameterSet"), nsmap={"ssv": SSV}, version="2.0", name=PARAMETER_SET,
                         generationTool="tiltload")
    parameters = etree.SubElement(root, _q(SSV, "Parameters"))
    for key, value in inst.parameters.items():
        v = variables.get(key)
        value = checked_value(inst.name, v, key, value)
        p = etree.SubElement(parameters, _q(SSV, "Parameter"), name=key)
        typed = etree.SubElement(p, _q(SSV, _type_name(md, v)), value=ssv_text(v, value))
        if fmi_type(v) == "Enumeration":
            typed.set("name", enumeration_name(v))
    return etree.tostring(root, pretty_print=True, xml_declaration=True, encoding="utf-8")


def export(system: System, out: Path, stop: float, schedule: str = "ordered") -> Path:
    """Write the system as an SSP 2.0 archive at out; it validates against the SSP 2.0 schemas or nothing is written."""
    from .. import jacobi

    mds = {i.name: read_fmu(i.fmu, i.name) for i in system.instances}
    check_members(system)
    system = jacobi.explicit(system, mds)
    members = {SSD_NAME: ssd_document(system, mds, stop, schedule)}
    for inst in system.instances:
        if inst.parameters:
            members[f"resources/{inst.name}.ssv"] = ssv_document(inst, mds[inst.name])
    for member, data in members.items():
        kinds = ("ssv2",) if member.endswith(".ssv") else ("ssd2", "ssd2_11")
        for kind in kinds:
            errors = schema_errors(data, kind)
            if errors:
                raise DescriptionError(f"{member} does not validate against the SSP 2.0 schema ({kind}): {errors[0]}")
    return write_package(system, out, members)

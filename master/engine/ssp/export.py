"""A system as an SSP 1.0 package: SystemStructure.ssd (every component with its typed connectors, every connection,
the default experiment), one SSV parameter set per component and the FMUs under resources/, checked against the SSP
1.0 schemas before anything is written. (FMI 3.0 systems: ssp2.py.) What the annotations carry: docs/master.md."""

from __future__ import annotations

import json
import zipfile
from pathlib import Path

from lxml import etree

from ..errors import DescriptionError
from ..system import Connection, Instance, System
from .schema import (
    ANNOTATION,
    FMU_TYPE,
    OSP_ANNOTATION,
    OSP_NS,
    PARAMETER_SET,
    SCHEDULES,
    SSD_NAME,
    SSD_NS,
    TL_NS,
    schema_errors,
)

_FIXED_DATE = (2016, 1, 1, 0, 0, 0)  # zip member times: the same export twice is the same bytes


def enumeration_name(v) -> str:
    """The SSP name of an Enumeration variable's type: its declared type's (the SSD's Enumerations list its items)."""
    return getattr(v.declaredType, "name", None) or v.name


def enumerations(ssd_ns: str, ssc_ns: str, mds: dict, wanted) -> etree._Element | None:
    """The SSD's Enumerations element: every enumeration type a connector or parameter of the package uses, with its
    items (wanted(instance, variable): is the variable in the package)."""
    from ..fmi.model_description import enumeration_items, fmi_type

    found: dict[str, list] = {}
    for name, md in mds.items():
        for v in md.modelVariables:
            if fmi_type(v) == "Enumeration" and wanted(name, v):
                found.setdefault(enumeration_name(v), enumeration_items(v))
    if not found:
        return None
    element = etree.Element(f"{{{ssd_ns}}}Enumerations")
    for name, items in found.items():
        e = etree.SubElement(element, f"{{{ssc_ns}}}Enumeration", name=name)
        for item, value in items:
            etree.SubElement(e, f"{{{ssc_ns}}}Item", name=item, value=str(value))
    return element


def ssv_text(v, value) -> str:
    """A parameter value as SSV writes it for the variable's type: an Enumeration by its item's name, a Binary in
    hexadecimal, a Boolean as true/false, an integer type's digits, a float's repr."""
    from ..fmi.model_description import FMI_TYPES, enumeration_items, fmi_type

    name = fmi_type(v)
    if name == "Enumeration":
        return next(item for item, x in enumeration_items(v) if x == value)
    if name == "Binary":
        return bytes(value).hex()
    if name == "Boolean":
        return str(bool(value)).lower()
    if name == "String":
        return str(value)
    return str(int(value)) if FMI_TYPES[name].bounds is not None else repr(float(value))


def _connector(v):
    from pyssp_standard.common_content_ssc import TypeBoolean, TypeEnumeration, TypeInteger, TypeReal, TypeString
    from pyssp_standard.ssd import Connector

    from ..fmi.model_description import fmi_type

    kind = v.causality if v.causality in ("input", "output") else "parameter"
    unit = v.declaredType.unit if v.unit is None and v.declaredType is not None else v.unit
    type_ = {"Float64": lambda: TypeReal(unit or None), "Int32": TypeInteger, "Boolean": TypeBoolean,
             "String": TypeString, "Enumeration": lambda: TypeEnumeration(enumeration_name(v))}[fmi_type(v)]()
    return Connector(name=v.name, kind=kind, type_=type_)


def _ssv(instance: Instance, md) -> bytes:
    """The instance's parameter values as an SSV parameter set, typed by the FMU's own declarations."""
    from pyssp_standard.parameter_types import ParameterType
    from pyssp_standard.ssv import Parameter, SSVElem

    from ..fmi.model_description import FMI2_TYPE, checked_value, fmi_type

    variables = {v.name: v for v in md.modelVariables}
    ssp_type = {fmi3: fmi2 for fmi2, fmi3 in FMI2_TYPE.items()}  # SSP 1.0 names the FMI 2.0 types
    params = []
    for key, value in instance.parameters.items():
        v = variables.get(key)
        value = checked_value(instance.name, v, key, value)
        attrs = {"value": ssv_text(v, value)}
        if v.type == "Real" and v.unit:
            attrs["unit"] = v.unit
        kind = ssp_type[fmi_type(v)]
        if kind == "Enumeration":  # the type whose items the SSD's Enumerations list (pyssp writes None otherwise)
            attrs["name"] = enumeration_name(v)
        typed = ParameterType(kind, attrs)
        typed.parameter = {k: x for k, x in typed.parameter.items() if x is not None}  # pyssp writes a missing unit as None
        params.append(Parameter(name=key, type_name=kind, type_value=typed))
    elem = SSVElem(name=PARAMETER_SET, parameters=params)
    elem.top_level_metadata.generationTool = "tiltload"
    elem.top_level_metadata.generationDateAndTime = ""
    root = elem.to_xml()
    for p in root.iter(f"{{{elem.namespaces['ssv']}}}Real"):  # units are declared in the SSD only
        p.attrib.pop("unit", None)
    return etree.tostring(root, pretty_print=True, xml_declaration=True, encoding="utf-8")


def _units(mds: dict):
    """Every unit the connectors use, with the SI base-unit exponents the FMUs' own UnitDefinitions declare."""
    from pyssp_standard.unit import BaseUnit, Unit, Units

    base = ("kg", "m", "s", "A", "K", "mol", "cd", "rad")
    units = Units()
    seen = set()
    for md in mds.values():
        declared = {u.name: u.baseUnit for u in md.unitDefinitions}
        for v in md.modelVariables:
            if v.type == "Real" and v.unit and v.unit not in seen:
                seen.add(v.unit)
                b = declared.get(v.unit)
                exps = {k: int(getattr(b, k)) for k in base if b is not None and getattr(b, k)}
                units.add_unit(Unit(v.unit, BaseUnit(exps)))
    return units


def master_annotation(system: System, schedule: str, delays: list[Connection]):
    from pyssp_standard.common_content_ssc import Annotation

    note = Annotation(ANNOTATION)
    master = etree.SubElement(note.root, f"{{{TL_NS}}}Master", nsmap={"tl": TL_NS},
                              tick=repr(system.tick), schedule=schedule,
                              **({"fmu_end": system.fmu_end} if system.fmu_end != "end" else {}))  # engine/edges.py
    for inst in system.instances:
        attrs = {"name": inst.name, "timing": inst.timing}
        if inst.period is not None:
            attrs["period"] = repr(inst.period)
        if inst.remote is not None:
            attrs["remote"] = inst.remote  # HOST:PORT of the tiltload serve it runs on (its secret comes with the run)
        if inst.fmi is not None:
            attrs["fmi"] = str(inst.fmi)
        etree.SubElement(master, f"{{{TL_NS}}}Instance", **attrs)
    for c in delays:
        etree.SubElement(master, f"{{{TL_NS}}}Delay", source=c.source, target=c.target, ticks=str(c.delay))
    if system.faults:
        from dataclasses import asdict

        faults = [{k: v for k, v in asdict(f).items() if v is not None and v != ""} for f in system.faults]
        etree.SubElement(master, f"{{{TL_NS}}}Faults").text = json.dumps(faults)
    return note


def osp_annotation(tick: float):
    from pyssp_standard.common_content_ssc import Annotation

    note = Annotation(OSP_ANNOTATION)
    algorithm = etree.SubElement(note.root, f"{{{OSP_NS}}}Algorithm", nsmap={"osp": OSP_NS})
    etree.SubElement(algorithm, f"{{{OSP_NS}}}FixedStepAlgorithm", baseStepSize=repr(tick))
    return note


def ssd_document(system: System, mds: dict, stop: float, schedule: str = "ordered", name: str = "tiltload") -> bytes:
    """The SystemStructure.ssd of a system whose connections are all explicit (jacobi.explicit)."""
    from pyssp_standard.ssd import SSD, Component, DefaultExperiment, ParameterBinding
    from pyssp_standard.ssd import Connection as SspConnection
    from pyssp_standard.ssd import System as SspSystem

    if schedule not in SCHEDULES:
        raise DescriptionError(f"schedule must be one of {', '.join(SCHEDULES)}, got {schedule!r}")
    ssd = SSD.__new__(SSD)  # an in-memory document: pyssp's SSD otherwise insists on a file
    SSD.__init__(ssd, Path("unused.ssd"), mode="w")
    ssd.name, ssd.version = name, "1.0"
    ssd.top_level_metadata.generationTool = "tiltload"
    ssd.top_level_metadata.generationDateAndTime = ""
    top = SspSystem(name=name)
    for inst in system.instances:
        comp = Component()
        comp.name, comp.component_type, comp.source = inst.name, FMU_TYPE, f"resources/{_fmu_member(inst)}"
        comp.connectors = [_connector(v) for v in mds[inst.name].modelVariables
                           if v.causality in ("input", "output") or v.name in inst.parameters]
        if inst.parameters:
            comp.parameter_bindings = [ParameterBinding(source=f"resources/{inst.name}.ssv")]
        top.elements.append(comp)
    for c in system.connections:
        (se, sc), (ee, ec) = c.source.split(".", 1), c.target.split(".", 1)
        top.connections.append(SspConnection(start_element=se, start_connector=sc, end_element=ee, end_connector=ec))
    top.annotations.add_annotation(master_annotation(system, schedule, [c for c in system.connections if c.delay]))
    ssd.system = top
    experiment = DefaultExperiment()
    experiment.start_time, experiment.stop_time = float(system.start_time), float(stop)
    experiment.annotations.add_annotation(osp_annotation(system.tick))
    ssd.default_experiment = experiment
    ssd.units = _units(mds)
    ssd.__write__()
    listed = {(inst.name, name) for inst in system.instances for name in inst.parameters}
    enums = enumerations(SSD_NS["ssd"], SSD_NS["ssc"], mds, lambda name, v: v.causality in ("input", "output")
                         or (name, v.name) in listed)
    if enums is not None:  # SSP 1.0 orders them after the System, before Units and DefaultExperiment
        ssd.root.insert(list(ssd.root).index(ssd.root.find("ssd:System", SSD_NS)) + 1, enums)
    experiment_elem = ssd.root.find("ssd:DefaultExperiment", SSD_NS)
    if experiment_elem is not None:  # SSP 1.0 orders Units before DefaultExperiment; pyssp-standard 0.9 does not
        ssd.root.remove(experiment_elem)
        ssd.root.append(experiment_elem)
    # namespaces declared once at the top: libcosim reads an element's xmlns attribute as a child element
    etree.cleanup_namespaces(ssd.root, top_nsmap={"osp": OSP_NS, "tl": TL_NS})
    return etree.tostring(ssd.root, pretty_print=True, xml_declaration=True, encoding="utf-8")


def _fmu_member(inst: Instance) -> str:
    return Path(inst.fmu).name


def check_members(system: System) -> None:
    """Two different FMU files of one name would collide in resources/; an input file has no place in a package."""
    for inst in system.instances:
        if inst.input_file is not None:
            raise DescriptionError(f"{inst.name}: its input file {inst.input_file} has no place in an SSP package "
                                   "(give it to `tiltload run --system PACKAGE --input-file`)")
        same = [i for i in system.instances if _fmu_member(i) == _fmu_member(inst) and Path(i.fmu).resolve() != Path(inst.fmu).resolve()]
        if same:
            raise DescriptionError(f"{inst.name} and {same[0].name} use different FMU files both called {_fmu_member(inst)}")


def export(system: System, out: Path, stop: float, schedule: str = "ordered") -> Path:
    """Write the system as an SSP archive at out; it validates against the SSP 1.0 schemas or nothing is written.
    (Systems with FMI 3.0 FMUs are SSP 2.0 packages: ssp2.export.)"""
    from .. import jacobi
    from ..fmi.model_description import read_fmu

    mds = {i.name: read_fmu(i.fmu, i.name) for i in system.instances}
    check_members(system)
    system = jacobi.explicit(system, mds)
    ssd = ssd_document(system, mds, stop, schedule)
    members = {SSD_NAME: ssd}
    for inst in system.instances:
        if inst.parameters:
            members[f"resources/{inst.name}.ssv"] = _ssv(inst, mds[inst.name])
    for member, data in members.items():
        errors = schema_errors(data, "ssv" if member.endswith(".ssv") else "ssd")
        if errors:
            raise DescriptionError(f"{member} does not validate against the SSP 1.0 schema: {errors[0]}")
    return write_package(system, out, members)


def write_package(system: System, out: Path, members: dict[str, bytes]) -> Path:
    """The archive: the documents given and every instance's FMU under resources/, written whole or not at all; the
    same package twice is the same bytes."""
    names = [_fmu_member(i) for i in system.instances]
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    partial = out.with_name(out.name + ".partial")
    with zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as z:
        for member, data in members.items():
            z.writestr(zipfile.ZipInfo(member, _FIXED_DATE), data, zipfile.ZIP_DEFLATED)
        for inst, member in zip(system.instances, names):
            if f"resources/{member}" not in z.namelist():
                z.writestr(zipfile.ZipInfo(f"resources/{member}", _FIXED_DATE), Path(inst.fmu).read_bytes(), zipfile.ZIP_STORED)
    partial.replace(out)
    return out

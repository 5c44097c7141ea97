"""SSP 1.0 packages of a system: the exchange format other masters (libcosim, Ecos) read, and ours. (A system with
FMI 3.0 FMUs is exported as SSP 2.0 by ssp2.py; load reads both.)

An export is one zip: SystemStructure.ssd (every component with its input, output and parameter
connectors, typed and with units; every connection written out; the default experiment) and, under
resources/, the FMUs and one SSV parameter set per component. The SSD is built with pyssp-standard's
object model and checked against the SSP 1.0 schemas it ships. What SSP has no element for travels in
annotations other masters ignore: tiltload's tick, periods, output timing, the `tiltload serve` an instance
runs on (remote="HOST:PORT"), connection delays, faults and the schedule the package was prepared for
(org.tiltload.master); the fixed step for libcosim
(com.opensimulationplatform).

JSON system descriptions stay as the hand-written format (auto-connection by name, a dozen lines);
SSP is what a run is exchanged as. Both load into the same System, so nothing exists in only one.
"""

from __future__ import annotations

import functools
import hashlib
import io
import json
import os
import threading
import zipfile
from pathlib import Path

from lxml import etree

from .errors import DescriptionError
from .system import Connection, Instance, System, validate

ANNOTATION = "org.tiltload.master"
TL_NS = "https://github.com/tiltload/ssp/1"
OSP_ANNOTATION = "com.opensimulationplatform"
OSP_NS = "http://opensimulationplatform.com/SSP/OSPAnnotations"
FMU_TYPE = "application/x-fmu-sharedlibrary"
SSD_NAME = "SystemStructure.ssd"
SCHEDULES = ("ordered", "jacobi")
PARAMETER_SET = "initialValues"  # every component's SSV set has this name: Ecos applies a set by name (init(parameter_set=...))
_FIXED_DATE = (2016, 1, 1, 0, 0, 0)  # zip member times: the same export twice is the same bytes


@functools.cache
def _schema(kind: str):  # building one takes 0.5 s
    import xmlschema
    from pyssp_standard.standard import ModelicaStandard

    version = xmlschema.XMLSchema11 if kind.endswith("_11") else xmlschema.XMLSchema10
    return version(str(ModelicaStandard.schemas[kind]))


def schema_errors(xml: bytes, kind: str = "ssd") -> list[str]:
    """The SSP schema's complaints about a document (kind ssd or ssv: SSP 1.0; ssd2, ssv2: SSP 2.0, ssd2_11 its XSD 1.1
    form, pyssp-standard's names); empty if it validates."""
    schema = _schema(kind)
    try:
        return [f"{e.path}: {e.reason}" for e in schema.iter_errors(io.BytesIO(xml))]
    except Exception as err:  # not XML at all
        return [str(err)]


# ----------------------------------------------------------------------------------------------- export

def _connector(v):
    from pyssp_standard.common_content_ssc import TypeBoolean, TypeInteger, TypeReal, TypeString
    from pyssp_standard.ssd import Connector

    kind = v.causality if v.causality in ("input", "output") else "parameter"
    unit = v.declaredType.unit if v.unit is None and v.declaredType is not None else v.unit
    type_ = {"Real": lambda: TypeReal(unit or None), "Integer": TypeInteger, "Boolean": TypeBoolean,
             "String": TypeString}[v.type]()
    return Connector(name=v.name, kind=kind, type_=type_)


def _ssv(instance: Instance, md) -> bytes:
    """The instance's parameter values as an SSV parameter set, typed by the FMU's own declarations."""
    from pyssp_standard.parameter_types import ParameterType
    from pyssp_standard.ssv import Parameter, SSVElem

    from .model_description import checked_value

    variables = {v.name: v for v in md.modelVariables}
    params = []
    for key, value in instance.parameters.items():
        v = variables.get(key)
        value = checked_value(instance.name, v, key, value)
        text = repr(float(value)) if v.type == "Real" else (str(bool(value)).lower() if v.type == "Boolean" else str(value))
        attrs = {"value": text}
        if v.type == "Real" and v.unit:
            attrs["unit"] = v.unit
        params.append(Parameter(name=key, type_name=v.type, type_value=ParameterType(v.type, attrs)))
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
                              tick=repr(system.tick), schedule=schedule)
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
    experiment.start_time, experiment.stop_time = 0.0, float(stop)
    experiment.annotations.add_annotation(osp_annotation(system.tick))
    ssd.default_experiment = experiment
    ssd.units = _units(mds)
    ssd.__write__()
    experiment_elem = ssd.root.find("ssd:DefaultExperiment", _SSD_NS)
    if experiment_elem is not None:  # SSP 1.0 orders Units before DefaultExperiment; pyssp-standard 0.9 does not
        ssd.root.remove(experiment_elem)
        ssd.root.append(experiment_elem)
    # namespaces declared once at the top: libcosim reads an element's xmlns attribute as a child element
    etree.cleanup_namespaces(ssd.root, top_nsmap={"osp": OSP_NS, "tl": TL_NS})
    return etree.tostring(ssd.root, pretty_print=True, xml_declaration=True, encoding="utf-8")


def _fmu_member(inst: Instance) -> str:
    return Path(inst.fmu).name


def check_members(system: System) -> None:
    """Two different FMU files of one name would collide in resources/."""
    for inst in system.instances:
        same = [i for i in system.instances if _fmu_member(i) == _fmu_member(inst) and Path(i.fmu).resolve() != Path(inst.fmu).resolve()]
        if same:
            raise DescriptionError(f"{inst.name} and {same[0].name} use different FMU files both called {_fmu_member(inst)}")


def export(system: System, out: Path, stop: float, schedule: str = "ordered") -> Path:
    """Write the system as an SSP archive at out; it validates against the SSP 1.0 schemas or nothing is written.
    (Systems with FMI 3.0 FMUs are SSP 2.0 packages: ssp2.export.)"""
    from . import jacobi
    from .model_description import read_fmu

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


# ----------------------------------------------------------------------------------------------- import

_SSD_NS = {"ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
           "ssc": "http://ssp-standard.org/SSP1/SystemStructureCommon",
           "ssv": "http://ssp-standard.org/SSP1/SystemStructureParameterValues", "tl": TL_NS}


# Limits on what an archive may unpack to: a package holds a few FMUs (the loop's is 0.45 MB; a big FMU with its
# resources, hundreds of MB), a zip bomb expands a thousandfold. Checked on the declared sizes before anything is
# written, and again on the bytes actually written (a declared size can lie).
MAX_UNPACKED = 1 << 30  # 1 GiB unpacked in all
MAX_RATIO = 100  # a member may expand at most 100-fold (the loop's SSD: 16-fold; FMUs hardly) ...
RATIO_FREE = 1 << 20  # ... unless it unpacks to at most 1 MiB
MAX_MEMBERS = 10_000
_BLOCK = 1 << 20


def package_digest(path: Path) -> str:
    """The archive's SHA-256, read in blocks (a large package is never held in memory)."""
    with open(path, "rb") as f:
        return hashlib.file_digest(f, "sha256").hexdigest()


def _unpack(path: Path, into: Path) -> Path:
    """The archive unpacked once into the folder into (FMUs are loaded from files), keyed by its content.

    Refused with one line, leaving nothing behind: a link or any other non-regular member, a name that leaves the
    package, more than MAX_MEMBERS members, more than MAX_UNPACKED bytes in all, a member that expands more than
    MAX_RATIO-fold (above RATIO_FREE bytes)."""
    import shutil

    folder = Path(into) / package_digest(path)[:20]
    if (folder / ".complete").exists():
        return folder
    partial = folder.with_name(f"{folder.name}.{os.getpid()}.{threading.get_ident()}.partial")  # one per unpacker
    shutil.rmtree(partial, ignore_errors=True)
    try:
        with zipfile.ZipFile(path) as z:
            members = _checked_members(path, z)
            partial.mkdir(parents=True)
            written = 0
            for info in members:
                target = partial / info.filename
                if info.is_dir():
                    target.mkdir(parents=True, exist_ok=True)
                    continue
                target.parent.mkdir(parents=True, exist_ok=True)
                written += _copy_member(path, z, info, target, MAX_UNPACKED - written)
        (partial / ".complete").write_text("")
        try:
            partial.rename(folder)  # fails if the folder is there: published by another unpacker, or a crash's leftover
        except OSError:
            if (folder / ".complete").exists():  # another process or thread unpacked the same package meanwhile
                shutil.rmtree(partial, ignore_errors=True)
            else:  # a folder without its mark is left from an unpacker that died; nobody else uses it
                shutil.rmtree(folder, ignore_errors=True)
                partial.rename(folder)
    except BaseException as err:
        shutil.rmtree(partial, ignore_errors=True)
        if isinstance(err, zipfile.BadZipFile):
            raise DescriptionError(f"{path}: the archive is damaged ({err})") from None
        if isinstance(err, OSError) and not isinstance(err, DescriptionError):
            raise DescriptionError(f"{path}: cannot unpack into {into}: {err.strerror or err}") from None
        raise
    return folder


def _checked_members(path: Path, z: zipfile.ZipFile) -> list[zipfile.ZipInfo]:
    """The archive's members, each a plain file or folder whose name stays inside the package; the declared sizes
    within the limits."""
    import stat

    members = z.infolist()
    if len(members) > MAX_MEMBERS:
        raise DescriptionError(f"{path}: the archive has {len(members)} members, more than the {MAX_MEMBERS} a package may have")
    total, seen = 0, set()
    for info in members:
        name = info.filename
        if name.rstrip("/") in seen:
            raise DescriptionError(f"{path}: archive member {name!r} appears twice")
        seen.add(name.rstrip("/"))
        mode = info.external_attr >> 16
        kind = stat.S_IFMT(mode)
        if stat.S_ISLNK(mode):
            raise DescriptionError(f"{path}: archive member {name!r} is a symbolic link: a package holds files only")
        if kind and not (stat.S_ISREG(mode) or stat.S_ISDIR(mode)):
            raise DescriptionError(f"{path}: archive member {name!r} is not a regular file: a package holds files only")
        parts = name.replace("\\", "/").split("/")
        if name.startswith(("/", "\\")) or ".." in parts or (parts and ":" in parts[0]) or "\0" in name:
            raise DescriptionError(f"{path}: archive member {name!r} points outside the package")
        total += info.file_size
        if info.file_size > RATIO_FREE and info.file_size > MAX_RATIO * max(info.compress_size, 1):
            raise DescriptionError(f"{path}: archive member {name!r} expands {info.file_size / max(info.compress_size, 1):.0f}-fold "
                                   f"(to {info.file_size / 2**20:.0f} MiB): more than the {MAX_RATIO}-fold a package may (a zip bomb?)")
    if total > MAX_UNPACKED:
        raise DescriptionError(f"{path}: the archive unpacks to {total / 2**20:.1f} MiB, more than the "
                               f"{MAX_UNPACKED // 2**20} MiB a package may")
    return members


def _copy_member(path: Path, z: zipfile.ZipFile, info: zipfile.ZipInfo, target: Path, room: int) -> int:
    """Stream one member to target, never past its declared size, the ratio or the room left; the bytes written."""
    limit = min(info.file_size, room)
    written = 0
    with z.open(info) as src, open(target, "xb") as dst:
        while block := src.read(_BLOCK):
            written += len(block)
            if written > limit:
                if written > room:
                    raise DescriptionError(f"{path}: the archive unpacks to more than the {MAX_UNPACKED // 2**20} MiB a package may")
                raise DescriptionError(f"{path}: archive member {info.filename!r} holds more than the {info.file_size} bytes it declares")
            dst.write(block)
    return written


def _inside(folder: Path, source: str, allow_external: bool, where: str, what: str) -> Path:
    """A file a package names, resolved; refused if it lies outside the package's folder unless allow_external."""
    resolved = (folder / source).resolve()
    if not allow_external and not resolved.is_relative_to(folder.resolve()):
        raise DescriptionError(f"{where}: its {what} {source!r} lies outside the package (--allow-external-fmus allows it)")
    return resolved


def _parameters(folder: Path, binding, where: str, allow_external: bool = False) -> dict:
    """One ParameterBinding's values: inline ParameterValues or an SSV file."""
    if binding.get("source"):
        ssv_path = _inside(folder, binding.get("source"), allow_external, where, "parameter set")
        try:
            data = ssv_path.read_bytes()
        except OSError:
            raise DescriptionError(f"{where}: parameter set {binding.get('source')} is not in the package") from None
        version = "2.0" if b'version="2.0"' in data[:400] else "1.0"
        errors = schema_errors(data, "ssv2" if version == "2.0" else "ssv")
        if errors:
            raise DescriptionError(f"{where}: {binding.get('source')} does not validate against the SSP {version} schema: "
                                   f"{errors[0]}")
        root = etree.fromstring(data)
    else:
        root = binding.find("ssd:ParameterValues/ssv:ParameterSet", _SSD_NS)
        if root is None:
            return {}
    values = {}
    for p in root.iterfind("ssv:Parameters/ssv:Parameter", _SSD_NS):
        typed = p[0]
        kind, text = etree.QName(typed).localname, typed.get("value")
        convert = {"Real": float, "Float64": float, "Integer": int, "Int32": int, "Boolean": lambda s: s.strip() in ("true", "1"),
                   "String": str}.get(kind)
        if convert is None:
            raise DescriptionError(f"{where}: parameter {p.get('name')} has the unsupported type {kind}")
        try:
            values[p.get("name")] = convert(text)
        except (TypeError, ValueError):
            raise DescriptionError(f"{where}: parameter {p.get('name')} = {text!r} is not a {kind}") from None
    return values


def load(path: Path, unpack_into: Path, allow_external: bool = False) -> tuple[System, float | None, str]:
    """An SSP archive (.ssp) or a bare SystemStructure file (.ssd, FMUs relative to it) as a System, with the default
    experiment's stop time and the schedule it was prepared for. An archive is unpacked once into a folder of
    unpack_into named by its content (_unpack: its limits). Every component's FMU and parameter set must lie in the
    package (the .ssd's folder for a bare one) unless allow_external."""
    path = Path(path)
    if not path.exists():
        raise DescriptionError(f"SSP package {path} does not exist")
    if path.suffix == ".ssp" or zipfile.is_zipfile(path):
        if not zipfile.is_zipfile(path):
            raise DescriptionError(f"{path} is not an SSP package (not a zip archive)")
        folder = _unpack(path, unpack_into)
        ssd_path = folder / SSD_NAME
        if not ssd_path.is_file():
            raise DescriptionError(f"{path} is not an SSP package (no {SSD_NAME})")
    else:
        folder, ssd_path = path.parent, path
    try:
        data = ssd_path.read_bytes()
    except OSError as err:
        raise DescriptionError(f"cannot read {ssd_path}: {err.strerror or err}") from None
    try:
        version = etree.fromstring(data).get("version", "1.0")
    except etree.XMLSyntaxError:
        version = "1.0"  # the schema check says what is wrong
    errors = schema_errors(data, "ssd2" if version == "2.0" else "ssd")
    if errors:
        raise DescriptionError(f"{path}: the system structure does not validate against the SSP {version} schema: {errors[0]}")
    root = etree.fromstring(data)
    top = root.find("ssd:System", _SSD_NS)
    master = top.find("ssd:Annotations/ssc:Annotation[@type='" + ANNOTATION + "']/tl:Master", _SSD_NS)
    tick = float(master.get("tick")) if master is not None else _osp_step(root)
    if tick is None:
        raise DescriptionError(f"{path}: no step size (neither a {ANNOTATION} nor a {OSP_ANNOTATION} annotation)")
    schedule = master.get("schedule", "ordered") if master is not None else "jacobi"
    timing = {e.get("name"): e for e in master.iterfind("tl:Instance", _SSD_NS)} if master is not None else {}
    instances = []
    for comp in top.iterfind("ssd:Elements/ssd:Component", _SSD_NS):
        name, source = comp.get("name"), comp.get("source")
        if comp.get("type", FMU_TYPE) != FMU_TYPE:
            raise DescriptionError(f"{path}: component {name} is a {comp.get('type')}, not an FMU")
        fmu = _inside(folder, source, allow_external, f"{path}: component {name}", "FMU")
        params = {}
        for binding in comp.iterfind("ssd:ParameterBindings/ssd:ParameterBinding", _SSD_NS):
            params.update(_parameters(folder, binding, f"{path}: component {name}", allow_external))
        extra = timing.get(name)
        period = float(extra.get("period")) if extra is not None and extra.get("period") else None
        fmi = extra.get("fmi") if extra is not None else None
        if fmi not in (None, "2", "3"):
            raise DescriptionError(f"{path}: component {name}: the FMI version must be 2 or 3, got {fmi!r}")
        instances.append(Instance(name, fmu, period, params,
                                  extra.get("timing", "sample") if extra is not None else "sample",
                                  remote=extra.get("remote") if extra is not None else None, fmi=int(fmi) if fmi else None))
    if not instances:
        raise DescriptionError(f"{path}: the system has no FMU component")
    delays = {}
    if master is not None:
        for d in master.iterfind("tl:Delay", _SSD_NS):
            try:
                delays[d.get("source"), d.get("target")] = int(d.get("ticks"))
            except (TypeError, ValueError):
                raise DescriptionError(f"{path}: delay {d.get('source')} -> {d.get('target')} is not a whole number of ticks") from None
    conns = []
    for c in top.iterfind("ssd:Connections/ssd:Connection", _SSD_NS):
        if not c.get("startElement") or not c.get("endElement"):
            raise DescriptionError(f"{path}: connection {c.get('startConnector')} -> {c.get('endConnector')} "
                                   "involves the system's own connectors (not supported)")
        src, dst = f"{c.get('startElement')}.{c.get('startConnector')}", f"{c.get('endElement')}.{c.get('endConnector')}"
        conns.append(Connection(src, dst, delays.pop((src, dst), 0)))
    if delays:
        (src, dst), _ = next(iter(delays.items()))
        raise DescriptionError(f"{path}: a delay names the connection {src} -> {dst}, which the system does not have")
    system = System(tick, instances, conns, auto_connect=False)
    faults = master.find("tl:Faults", _SSD_NS) if master is not None else None
    if faults is not None and faults.text:
        from .manipulators import parse

        try:
            system.faults = parse(json.loads(faults.text), f"{path}: faults")
        except json.JSONDecodeError as err:
            raise DescriptionError(str(err)) from None
    experiment = root.find("ssd:DefaultExperiment", _SSD_NS)
    stop = float(experiment.get("stopTime")) if experiment is not None and experiment.get("stopTime") else None
    return validate(system), stop, schedule


def _osp_step(root) -> float | None:
    step = root.find(f".//{{{OSP_NS}}}FixedStepAlgorithm")
    return float(step.get("baseStepSize")) if step is not None and step.get("baseStepSize") else None

"""An SSP package (1.0 or 2.0, an archive or a bare .ssd) loaded as a System, with its stop time and schedule."""

from __future__ import annotations

import json
import zipfile
from pathlib import Path

from lxml import etree

from ..errors import DescriptionError
from ..system import Connection, Instance, System, validate
from .schema import ANNOTATION, FMU_TYPE, OSP_ANNOTATION, OSP_NS, SSD_NAME, SSD_NS, schema_errors
from .zip_unpack import unpack


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
        root = binding.find("ssd:ParameterValues/ssv:ParameterSet", SSD_NS)
        if root is None:
            return {}
    values = {}
    for p in root.iterfind("ssv:Parameters/ssv:Parameter", SSD_NS):
        typed = p[0]
        kind, text = etree.QName(typed).localname, typed.get("value")
        convert = {"Real": float, "Float64": float, "Float32": float, "Integer": int,
                   **dict.fromkeys(("Int8", "UInt8", "Int16", "UInt16", "Int32", "UInt32", "Int64", "UInt64"), int),
                   "Boolean": lambda s: s.strip() in ("true", "1"), "String": str,
                   "Enumeration": str, "Binary": bytes.fromhex}.get(kind)  # an item's name: checked_value maps it
        if convert is None:
            raise DescriptionError(f"{where}: parameter {p.get('name')} has the unsupported type {kind}")
        try:
            values[p.get("name")] = convert(text)
        except (TypeError, ValueError):
            raise DescriptionError(f"{where}: parameter {p.get('name')} = {text!r} is not a {kind}") from None
    return values


def load(path: Path, unpack_into: Path, allow_external: bool = False, say=None,
         step: float | None = None) -> tuple[System, float | None, str]:
    """An SSP archive (.ssp) or a bare SystemStructure file (.ssd, FMUs relative to it) as a System, with the default
    experiment's stop time and the schedule it was prepared for. An archive is unpacked once into a folder of
    unpack_into named by its content (_unpack: its limits). Every component's FMU and parameter set must lie in the
    package (the .ssd's folder for a bare one) unless allow_external. A package without a step annotation (tiltload's
    or libcosim's) takes its step from step (--step) or its FMUs (_declared_steps), which say(line) tells."""
    path = Path(path)
    if not path.exists():
        raise DescriptionError(f"SSP package {path} does not exist")
    if path.suffix == ".ssp" or zipfile.is_zipfile(path):
        if not zipfile.is_zipfile(path):
            raise DescriptionError(f"{path} is not an SSP package (not a zip archive)")
        folder = unpack(path, unpack_into)
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
    top = root.find("ssd:System", SSD_NS)
    master = top.find("ssd:Annotations/ssc:Annotation[@type='" + ANNOTATION + "']/tl:Master", SSD_NS)
    tick = float(master.get("tick")) if master is not None else _osp_step(root)
    if tick is not None and step is not None:
        raise DescriptionError(f"{path}: the package declares its step ({tick:g} s, in its "
                               f"{ANNOTATION if master is not None else OSP_ANNOTATION} annotation); --step is for a "
                               "package that declares none")
    experiment = root.find("ssd:DefaultExperiment", SSD_NS)
    start = float(experiment.get("startTime") or 0) if experiment is not None else 0.0
    if not 0 <= start < float("inf"):
        raise DescriptionError(f"{path}: its DefaultExperiment starts at {start:g} s; tiltload runs a system from a time "
                               "of 0 s or later")
    schedule = master.get("schedule", "ordered") if master is not None else "jacobi"
    timing = {e.get("name"): e for e in master.iterfind("tl:Instance", SSD_NS)} if master is not None else {}
    instances = []
    for comp in top.iterfind("ssd:Elements/ssd:Component", SSD_NS):
        name, source = comp.get("name"), comp.get("source")
        if comp.get("type", FMU_TYPE) != FMU_TYPE:
            raise DescriptionError(f"{path}: component {name} is a {comp.get('type')}, not an FMU")
        fmu = _inside(folder, source, allow_external, f"{path}: component {name}", "FMU")
        params = {}
        for binding in comp.iterfind("ssd:ParameterBindings/ssd:ParameterBinding", SSD_NS):
            params.update(_parameters(folder, binding, f"{path}: component {name}", allow_external))
        extra = timing.get(name)
        period = float(extra.get("period")) if extra is not None and extra.get("period") else None
        fmi = extra.get("fmi") if extra is not None else None
        if fmi not in (None, "2", "3"):
            raise DescriptionError(f"{path}: component {name}: the FMI version must be 2 or 3, got {fmi!r}")
        instances.append(Instance(name, fmu, period, params,
                                  extra.get("timing", "continuous") if extra is not None else "continuous",
                                  remote=extra.get("remote") if extra is not None else None, fmi=int(fmi) if fmi else None))
    if not instances:
        raise DescriptionError(f"{path}: the system has no FMU component")
    if tick is None:
        tick = _declared_steps(path, instances, say, step)
    delays = {}
    if master is not None:
        for d in master.iterfind("tl:Delay", SSD_NS):
            try:
                delays[d.get("source"), d.get("target")] = int(d.get("ticks"))
            except (TypeError, ValueError):
                raise DescriptionError(f"{path}: delay {d.get('source')} -> {d.get('target')} is not a whole number of ticks") from None
    conns = []
    for c in top.iterfind("ssd:Connections/ssd:Connection", SSD_NS):
        if not c.get("startElement") or not c.get("endElement"):
            raise DescriptionError(f"{path}: connection {c.get('startConnector')} -> {c.get('endConnector')} "
                                   "involves the system's own connectors (not supported)")
        src, dst = f"{c.get('startElement')}.{c.get('startConnector')}", f"{c.get('endElement')}.{c.get('endConnector')}"
        conns.append(Connection(src, dst, delays.pop((src, dst), 0)))
    if delays:
        (src, dst), _ = next(iter(delays.items()))
        raise DescriptionError(f"{path}: a delay names the connection {src} -> {dst}, which the system does not have")
    fmu_end = master.get("fmu_end", "end") if master is not None else "end"  # what an FMU's request to end is
    if fmu_end not in ("end", "error"):
        raise DescriptionError(f"{path}: fmu_end must be 'end' or 'error', got {fmu_end!r}")
    system = System(tick, instances, conns, auto_connect=False, fmu_end=fmu_end, start_time=start)  # FMPy's start
    faults = master.find("tl:Faults", SSD_NS) if master is not None else None
    if faults is not None and faults.text:
        from ..faults.parse import parse

        try:
            system.faults = parse(json.loads(faults.text), f"{path}: faults")
        except json.JSONDecodeError as err:
            raise DescriptionError(str(err)) from None
    stop = float(experiment.get("stopTime")) if experiment is not None and experiment.get("stopTime") else None
    if stop is not None and stop < start:
        raise DescriptionError(f"{path}: its DefaultExperiment stops at {stop:g} s, before its start ({start:g} s)")
    return validate(system), stop, schedule


def _declared_steps(path: Path, instances: list[Instance], say, given: float | None = None) -> float:
    """The step of a package that declares none (SSP has no master step; libcosim reads its own annotation): given
    (--step: every FMU steps at it), else the smallest of its FMUs' DefaultExperiment step sizes is the tick, and an
    FMU whose step is a whole number of ticks steps at its own (its period); said in one line."""
    from ..fmi.model_description import read_fmu

    steps = {}
    for inst in instances:
        experiment = read_fmu(inst.fmu, inst.name).defaultExperiment
        step = experiment.stepSize if experiment is not None else None
        if step is not None and float(step) > 0:
            steps[inst.name] = float(step)
    if not steps and given is None:
        raise DescriptionError(f"{path}: no step size: neither a {ANNOTATION} nor a {OSP_ANNOTATION} annotation, nor a "
                               "DefaultExperiment stepSize in any of its FMUs; give one with --step")
    tick = given if given is not None else min(steps.values())
    for inst in instances if given is None else ():
        n = round(steps.get(inst.name, tick) / tick)
        if n > 1 and abs(n * tick - steps[inst.name]) <= 1e-9 * steps[inst.name]:
            inst.period = n * tick
    if say is not None:
        declared = ", ".join(f"{name} {step:g} s" for name, step in steps.items()) or "none"
        why = ("--step, every FMU at it" if given is not None else
               "the smallest of its FMUs' DefaultExperiment step sizes, each FMU at its own where it is a whole number "
               "of steps")
        say(f"{path.name}: no step annotation; step {tick:g} s ({why}; declared: {declared})")
    return tick


def _osp_step(root) -> float | None:
    step = root.find(f".//{{{OSP_NS}}}FixedStepAlgorithm")
    return float(step.get("baseStepSize")) if step is not None and step.get("baseStepSize") else None

"""modelDescription.xml and the C tables of a native FMU, both written from its FmuDefinition."""

from __future__ import annotations

import hashlib
import uuid
import xml.etree.ElementTree as ET

from .units import base_exponents
from .variables import FmuDefinition, Variable

LOG_CATEGORIES = (("logStatusError", "errors: invalid parameters or inputs, refused calls"),
                  ("logStatusDiscard", "refused steps (diverged state)"),
                  ("logEvents", "informational messages: initialization summary"))


def c_array(name: str, a, ctype: str = "double") -> str:
    """A constant C array of the values (doubles written exactly, with repr), for a generated data header."""
    import numpy as np

    flat = np.asarray(a, dtype=float).ravel()
    body = ", ".join(repr(float(x)) for x in flat) if ctype == "double" else ", ".join(str(int(x)) for x in flat)
    return f"static const {ctype} {name}[{flat.size}] = {{{body}}};"


def guid(definition: FmuDefinition, digest: str) -> str:
    """Deterministic GUID: the same sources and variables always give the same FMU identity."""
    h = hashlib.sha256(digest.encode())
    for v in definition.variables:
        h.update(repr((v.name, v.type, v.causality, v.variability, v.unit)).encode())
    return "{" + str(uuid.UUID(bytes=h.digest()[:16], version=5)) + "}"


def start_text(v: Variable) -> str:
    """A start value as the model description writes it."""
    if v.type == "Real":
        return repr(float(v.start))
    if v.type == "Integer":
        return str(int(v.start))
    if v.type == "Boolean":
        return "true" if v.start else "false"
    return str(v.start)


def model_description(definition: FmuDefinition, guid_: str, source_files: list[str], tool: str) -> bytes:
    d = definition
    root = ET.Element("fmiModelDescription", {
        "fmiVersion": "2.0", "modelName": d.model_identifier, "guid": guid_, "description": d.description,
        "author": "tiltload", "version": d.version, "generationTool": tool, "variableNamingConvention": "flat",
        "numberOfEventIndicators": "0"})
    cs = ET.SubElement(root, "CoSimulation", {
        "modelIdentifier": d.model_identifier, "needsExecutionTool": "false",
        "canHandleVariableCommunicationStepSize": "true" if d.variable_step else "false",
        "canInterpolateInputs": "false", "maxOutputDerivativeOrder": "0", "canRunAsynchronuously": "false",
        "canBeInstantiatedOnlyOncePerProcess": "false", "canNotUseMemoryManagementFunctions": "false",
        "canGetAndSetFMUstate": "true", "canSerializeFMUstate": "true", "providesDirectionalDerivative": "false"})
    files = ET.SubElement(cs, "SourceFiles")
    for name in source_files:
        ET.SubElement(files, "File", {"name": name})
    units = sorted({v.unit for v in d.variables if v.unit})
    if units:
        defs = ET.SubElement(root, "UnitDefinitions")
        for unit in units:
            u = ET.SubElement(defs, "Unit", {"name": unit})
            ET.SubElement(u, "BaseUnit", {k: str(e) for k, e in base_exponents(unit).items()})
    cats = ET.SubElement(root, "LogCategories")
    for name, what in LOG_CATEGORIES:
        ET.SubElement(cats, "Category", {"name": name, "description": what})
    start, stop, step = d.default_experiment
    ET.SubElement(root, "DefaultExperiment", {"startTime": repr(start), "stopTime": repr(stop), "stepSize": repr(step)})
    mv = ET.SubElement(root, "ModelVariables")
    outputs = []
    for index, v in enumerate(d.variables, start=1):
        attrs = {"name": v.name, "valueReference": str(d.vr(v.name)), "causality": v.causality, "variability": v.variability}
        if v.causality == "output":
            attrs["initial"] = "calculated"
            outputs.append(index)
        elif v.causality == "parameter":
            attrs["initial"] = "exact"
        if v.description:
            attrs["description"] = v.description
        sv = ET.SubElement(mv, "ScalarVariable", attrs)
        typed = {"start": start_text(v)} if v.has_start else {}
        if v.unit:
            typed["unit"] = v.unit
        for key, bound in (("min", v.minimum), ("max", v.maximum)):
            if bound is not None:
                typed[key] = repr(bound)
        ET.SubElement(sv, v.type, typed)
    ms = ET.SubElement(root, "ModelStructure")
    for tag in ("Outputs", "InitialUnknowns"):
        block = ET.SubElement(ms, tag)
        for index in outputs:
            ET.SubElement(block, "Unknown", {"index": str(index)})
    ET.indent(root)
    return b'<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="utf-8") + b"\n"


def c_string(s: str) -> str:
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"') + '"'


def c_header(definition: FmuDefinition, guid_: str, fmi_version: int = 2, extra: tuple[str, ...] = ()) -> str:
    """tl_model.h: counts, value-reference macros and the model state's header; extra: lines of another layer
    (FMI 3.0: describe_fmi3.c_header)."""
    d = definition
    n_clock = len(d.clocks) if fmi_version == 3 else 0
    lines = [f"/* Generated by tiltload.native_fmu from the variable table of {d.model_identifier}: do not edit. */",
             "#ifndef TL_MODEL_H", "#define TL_MODEL_H", "", '#include "tl_platform.h"', "",
             f"#define TL_MODEL_IDENTIFIER {c_string(d.model_identifier)}", f"#define TL_GUID {c_string(guid_)}",
             f"#define TL_FMI_VERSION {fmi_version}", f"#define TL_N_CLOCK {n_clock}", f"#define TL_CAP_CLOCK {max(n_clock, 1)}",
             f"#define TL_STRING_LEN {d.string_length}"]
    for t in ("Real", "Integer", "Boolean", "String"):
        n = len(d.of_type(t))
        lines.append(f"#define TL_N_{t.upper()} {n}")
        lines.append(f"#define TL_CAP_{t.upper()} {max(n, 1)}")
    if fmi_version == 2:  # each type numbers its variables from 0 (FMI 3.0's bases come in extra)
        lines += [f"#define TL_VR_{t.upper()}0 0" for t in ("Real", "Integer", "Boolean", "String")]
    lines.append("")
    for v in d.variables:
        lines.append(f"#define TL_{v.type.upper()}_{v.name} {d.vr(v.name)}")
    lines += ["", "/* how a variable may be set: 0 never (output), 1 before exitInitializationMode (parameter), 2 always (input) */"]
    for t in ("Real", "Integer", "Boolean", "String"):
        lines.append(f"TL_INTERNAL extern const unsigned char tl_{t.lower()}_settable[TL_CAP_{t.upper()}];")
        lines.append(f"TL_INTERNAL extern const char* const tl_{t.lower()}_name[TL_CAP_{t.upper()}];")
    lines += ["TL_INTERNAL extern const double tl_real_start[TL_CAP_REAL];",
              "TL_INTERNAL extern const int tl_integer_start[TL_CAP_INTEGER];",
              "TL_INTERNAL extern const int tl_boolean_start[TL_CAP_BOOLEAN];",
              "TL_INTERNAL extern const char* const tl_string_start[TL_CAP_STRING];"]
    lines += [*extra, "", f'#include "{d.model_header}"', "", "#endif", ""]
    return "\n".join(lines)


def c_tables(definition: FmuDefinition, extra: tuple[str, ...] = ()) -> str:
    """tl_model_tables.c: names, settability and start values by value reference; extra: another layer's tables."""
    d = definition
    settable = {"output": "0", "parameter": "1", "input": "2"}  # 2: any time (inputs and tunable parameters)
    lines = [f"/* Generated by tiltload.native_fmu from the variable table of {d.model_identifier}: do not edit. */",
             '#include "tl_model.h"', ""]
    for t in ("Real", "Integer", "Boolean", "String"):
        vs = d.of_type(t)
        cap = f"TL_CAP_{t.upper()}"
        names = ", ".join(c_string(v.name) for v in vs) or "0"
        sett = ", ".join("2" if v.tunable else settable[v.causality] for v in vs) or "0"
        lines.append(f"const char* const tl_{t.lower()}_name[{cap}] = {{{names}}};")
        lines.append(f"const unsigned char tl_{t.lower()}_settable[{cap}] = {{{sett}}};")
        if t == "Real":
            starts = ", ".join(repr(float(v.start)) if v.has_start else "0.0" for v in vs) or "0.0"
            lines.append(f"const double tl_real_start[{cap}] = {{{starts}}};")
        elif t == "String":
            starts = ", ".join(c_string(str(v.start)) if v.has_start else '""' for v in vs) or '""'
            lines.append(f"const char* const tl_string_start[{cap}] = {{{starts}}};")
        else:
            starts = ", ".join(str(int(v.start)) if v.has_start else "0" for v in vs) or "0"
            lines.append(f"const int tl_{t.lower()}_start[{cap}] = {{{starts}}};")
        lines.append("")
    return "\n".join([*lines, *extra])

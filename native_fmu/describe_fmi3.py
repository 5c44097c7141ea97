"""The FMI 3.0 co-simulation documents of a native FMU, written from the same FmuDefinition as the FMI 2.0 ones:
modelDescription.xml, sources/buildDescription.xml, and the C tables the FMI 3.0 layer (c/tl_fmi3.c) adds.

Value references are unique across types in FMI 3.0 (References): 0 is the independent variable `time`,
1..n the clocks, then the Reals (Float64), Integers (Int32), Booleans and Strings, each type in table order.
The C tables keep indexing each type from 0; the layer subtracts the type's base.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from decimal import Decimal

from . import describe_fmi2
from .units import base_exponents, display_units
from .variables import TYPES, Clock, DefinitionError, FmuDefinition, Variable

FMI3_TYPE = {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean", "String": "String"}
TIME_VR = 0


@dataclass(frozen=True)
class References:
    """The FMI 3.0 value references of a definition."""

    definition: FmuDefinition

    @property
    def base(self) -> dict[str, int]:
        out, next_vr = {}, 1 + len(self.definition.clocks)
        for t in TYPES:
            out[t] = next_vr
            next_vr += len(self.definition.of_type(t))
        return out

    def of(self, name: str) -> int:
        v = next(x for x in self.definition.variables if x.name == name)
        return self.base[v.type] + self.definition.vr(name)

    def clock(self, name: str) -> int:
        return 1 + self.definition.clock_index(name)


def fraction(interval: float) -> tuple[int, int]:
    """(intervalCounter, resolution) with interval = counter / resolution exactly in decimal: 0.012 s -> (12, 1000)."""
    exact = Decimal(repr(interval))
    resolution = 1
    while (exact * resolution) != (exact * resolution).to_integral_value():
        resolution *= 10
        if resolution > 10**12:
            raise DefinitionError(f"clock interval {interval!r} s has no decimal form of at most 12 digits")
    return int(exact * resolution), resolution


def check(definition: FmuDefinition) -> None:
    """What FMI 3.0 asks of a clocked FMU beyond the schema (fmpy validate does not check these)."""
    for v in definition.variables:
        if v.clock and v.variability not in ("discrete", "tunable"):
            raise DefinitionError(f"{definition.model_identifier}.{v.name}: a clocked variable must be discrete")


def _unit_definitions(root: ET.Element, d: FmuDefinition) -> None:
    units = sorted({v.unit for v in d.variables if v.unit} | {"s"})
    defs = ET.SubElement(root, "UnitDefinitions")
    for unit in units:
        u = ET.SubElement(defs, "Unit", {"name": unit})
        ET.SubElement(u, "BaseUnit", {k: str(e) for k, e in base_exponents(unit).items()})
        for name, factor in display_units(unit):
            ET.SubElement(u, "DisplayUnit", {"name": name, "factor": repr(factor)})


def _clock(mv: ET.Element, refs: References, k: Clock) -> None:
    counter, resolution = fraction(k.interval)
    attrs = {"name": k.name, "valueReference": str(refs.clock(k.name)), "causality": "input", "variability": "discrete",
             "intervalVariability": "constant", "intervalDecimal": repr(k.interval), "shiftDecimal": "0",
             "supportsFraction": "true", "resolution": str(resolution), "intervalCounter": str(counter), "shiftCounter": "0"}
    if k.priority is not None:
        attrs["priority"] = str(k.priority)
    if k.description:
        attrs["description"] = k.description
    ET.SubElement(mv, "Clock", attrs)


def _variable(mv: ET.Element, refs: References, v: Variable) -> None:
    attrs = {"name": v.name, "valueReference": str(refs.of(v.name)), "causality": v.causality, "variability": v.variability}
    if v.description:
        attrs["description"] = v.description
    if v.clock:
        attrs["clocks"] = str(refs.clock(v.clock))
    if v.causality == "output" and not v.clock:
        attrs["initial"] = "calculated"
    elif v.causality == "parameter":
        attrs["initial"] = "exact"
    if v.has_start and v.type != "String":
        attrs["start"] = describe_fmi2.start_text(v)
    if v.unit:
        attrs["unit"] = v.unit
        shown = display_units(v.unit)
        if shown:
            attrs["displayUnit"] = shown[0][0]
    for key, bound in (("min", v.minimum), ("max", v.maximum)):
        if bound is not None:
            attrs[key] = repr(bound)
    element = ET.SubElement(mv, FMI3_TYPE[v.type], attrs)
    if v.has_start and v.type == "String":
        ET.SubElement(element, "Start", {"value": str(v.start)})


def in_reference_order(d: FmuDefinition) -> list[Variable]:
    return [v for t in TYPES for v in d.of_type(t)]


def model_description(definition: FmuDefinition, token: str, tool: str) -> bytes:
    """modelDescription.xml (FMI 3.0 co-simulation). A definition with clocks is the clocked variant: Event Mode, one
    periodic input clock per entry of definition.clocks; without, the plain variant (no Event Mode). A scheduled
    definition is the Scheduled Execution variant: the same variables and clocks, each clock a model partition with its
    priority."""
    d = definition
    check(d)
    refs = References(d)
    clocked = bool(d.clocks)
    root = ET.Element("fmiModelDescription", {
        "fmiVersion": "3.0", "modelName": d.model_identifier, "instantiationToken": token, "description": d.description,
        "author": "tiltload", "version": d.version, "generationTool": tool, "variableNamingConvention": "flat"})
    common = {"modelIdentifier": d.model_identifier, "needsExecutionTool": "false",
              "canBeInstantiatedOnlyOncePerProcess": "false", "canGetAndSetFMUState": "true", "canSerializeFMUState": "true",
              "providesDirectionalDerivatives": "false", "providesAdjointDerivatives": "false",
              "providesPerElementDependencies": "false"}
    if d.scheduled:  # one model partition per clock, activated by the importer's scheduler (FMI 3.0, ch. 5)
        ET.SubElement(root, "ScheduledExecution", common)
    else:
        ET.SubElement(root, "CoSimulation", {
            **common, "canHandleVariableCommunicationStepSize": "true" if d.variable_step or clocked else "false",
            "maxOutputDerivativeOrder": "0", "providesIntermediateUpdate": "false", "mightReturnEarlyFromDoStep": "false",
            "canReturnEarlyAfterIntermediateUpdate": "false", "hasEventMode": "true" if clocked else "false",
            "providesEvaluateDiscreteStates": "false"})
    _unit_definitions(root, d)
    cats = ET.SubElement(root, "LogCategories")
    for name, what in describe_fmi2.LOG_CATEGORIES:
        ET.SubElement(cats, "Category", {"name": name, "description": what})
    start, stop, step = d.default_experiment
    ET.SubElement(root, "DefaultExperiment", {"startTime": repr(start), "stopTime": repr(stop), "stepSize": repr(step)})
    mv = ET.SubElement(root, "ModelVariables")
    ET.SubElement(mv, "Float64", {"name": "time", "valueReference": str(TIME_VR), "causality": "independent",
                                  "variability": "continuous", "unit": "s", "description": "simulation time"})
    for k in d.clocks:
        _clock(mv, refs, k)
    ordered = in_reference_order(d)
    for v in ordered:
        _variable(mv, refs, v)
    ms = ET.SubElement(root, "ModelStructure")
    outputs = [v for v in ordered if v.causality == "output"]
    for v in outputs:
        ET.SubElement(ms, "Output", {"valueReference": str(refs.of(v.name))})
    for v in outputs:
        if not v.clock:  # clocked outputs are set at their clock's first tick, not at initialization
            ET.SubElement(ms, "InitialUnknown", {"valueReference": str(refs.of(v.name))})
    ET.indent(root)
    return b'<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="utf-8") + b"\n"


def build_description(definition: FmuDefinition, c_files: list[str]) -> bytes:
    """sources/buildDescription.xml: one platform-independent C11 configuration (an importer supplies the fmi3
    headers; FMPy's `fmpy compile` reads the first file set only, so there is one)."""
    root = ET.Element("fmiBuildDescription", {"fmiVersion": "3.0"})
    config = ET.SubElement(root, "BuildConfiguration", {
        "modelIdentifier": definition.model_identifier,
        "description": "any platform: a C11 compiler and libm; the fmi3 headers come from the importer"})
    files = ET.SubElement(config, "SourceFileSet", {"name": "tiltload", "language": "C11"})
    for name in c_files:
        ET.SubElement(files, "SourceFile", {"name": name})
    ET.SubElement(files, "PreprocessorDefinition", {
        "name": "CASADI_SYMBOL_EXPORT", "value": "", "description": "the CasADi-generated functions are not exported"})
    ET.indent(root)
    return b'<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="utf-8") + b"\n"


# ---- the C tables of the FMI 3.0 layer -------------------------------------------------------------------

def c_header(definition: FmuDefinition, token: str) -> str:
    """tl_model.h of an FMI 3.0 build: the FMI 2.0 one's macros, the value-reference bases, the clocks."""
    d = definition
    base = References(d).base
    lines = ["", "/* FMI 3.0: value references unique across types (native_fmu/describe_fmi3.py, References) */",
             f"#define TL_VR_TIME {TIME_VR}", "#define TL_VR_CLOCK0 1",
             f"#define TL_SCHEDULED {int(d.scheduled)} /* Scheduled Execution: a model partition per clock */"]
    lines += [f"#define TL_VR_{t.upper()}0 {base[t]}" for t in TYPES]
    lines += [f"#define TL_CLOCK_{k.name} {i}" for i, k in enumerate(d.clocks)]
    lines += ["/* a variable's clock (-1: none) and whether it is discrete, by type and index */"]
    for t in TYPES:
        lines.append(f"TL_INTERNAL extern const int tl_{t.lower()}_clock[TL_CAP_{t.upper()}];")
        lines.append(f"TL_INTERNAL extern const unsigned char tl_{t.lower()}_discrete[TL_CAP_{t.upper()}];")
    lines += ["TL_INTERNAL extern const char* const tl_clock_name[TL_CAP_CLOCK];",
              "TL_INTERNAL extern const double tl_clock_interval[TL_CAP_CLOCK];",
              "TL_INTERNAL extern const unsigned long long tl_clock_counter[TL_CAP_CLOCK];",
              "TL_INTERNAL extern const unsigned long long tl_clock_resolution[TL_CAP_CLOCK];"]
    return describe_fmi2.c_header(d, token, 3, tuple(lines))


def c_tables(definition: FmuDefinition) -> str:
    d = definition
    lines = ["/* FMI 3.0 */"]
    for t in TYPES:
        vs = d.of_type(t)
        cap = f"TL_CAP_{t.upper()}"
        clocks = ", ".join(str(d.clock_index(v.clock) if v.clock else -1) for v in vs) or "-1"
        discrete = ", ".join("1" if v.variability == "discrete" else "0" for v in vs) or "0"
        lines.append(f"const int tl_{t.lower()}_clock[{cap}] = {{{clocks}}};")
        lines.append(f"const unsigned char tl_{t.lower()}_discrete[{cap}] = {{{discrete}}};")
    fractions = [fraction(k.interval) for k in d.clocks]
    rows = (("const char* const tl_clock_name", [describe_fmi2.c_string(k.name) for k in d.clocks], "0"),
            ("const double tl_clock_interval", [repr(k.interval) for k in d.clocks], "0.0"),
            ("const unsigned long long tl_clock_counter", [f"{c}ULL" for c, _ in fractions], "0"),
            ("const unsigned long long tl_clock_resolution", [f"{r}ULL" for _, r in fractions], "1"))
    for declaration, values, empty in rows:
        lines.append(f"{declaration}[TL_CAP_CLOCK] = {{{', '.join(values) or empty}}};")
    lines.append("")
    return describe_fmi2.c_tables(d, tuple(lines))

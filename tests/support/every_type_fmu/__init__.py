"""Small FMUs with a variable of every FMI type (FMI 2.0 and 3.0), for the engine's type tests: a parameter p_T, an
input u_T and an output y_T of each type T (every_type2.c, every_type3.c say the model), the modelDescription.xml
written here, the C compiled with the machine's cc against FMPy's FMI headers."""

from __future__ import annotations

import subprocess
import zipfile
from pathlib import Path

import fmpy

HERE = Path(__file__).parent
HEADERS = Path(fmpy.__file__).parent / "c-code"
# the types of each version in value-reference order (index i: p 100 + i, u 200 + i, y 300 + i)
FMI3_TYPES = ("Float32", "Float64", "Int8", "UInt8", "Int16", "UInt16", "Int32", "UInt32", "Int64", "UInt64", "Boolean",
              "Enumeration")
FMI2_TYPES = ("Real", "Integer", "Boolean", "Enumeration")
ITEMS = (("red", 1), ("green", 2), ("blue", 3))


def _start(t: str) -> str:
    return "false" if t == "Boolean" else "1" if t == "Enumeration" else "0"


def _fmi3_xml(extra: str = "") -> str:
    rows = ['<Float64 name="time" valueReference="0" causality="independent" variability="continuous"/>']
    for i, t in enumerate(FMI3_TYPES):
        kind = "continuous" if t.startswith("Float") else "discrete"
        declared = ' declaredType="Colour"' if t == "Enumeration" else ""
        rows.append(f'<{t} name="p_{t}" valueReference="{100 + i}" causality="parameter" variability="fixed"{declared} '
                    f'start="{_start(t)}"/>')
        rows.append(f'<{t} name="u_{t}" valueReference="{200 + i}" causality="input" variability="{kind}"{declared} '
                    f'start="{_start(t)}"/>')
        rows.append(f'<{t} name="y_{t}" valueReference="{300 + i}" causality="output" variability="{kind}"{declared}/>')
    # each output depends directly on its input (declared: the engine finds an algebraic loop by it)
    rows += ['<String name="p_String" valueReference="112" causality="parameter" variability="fixed"><Start value="p"/>'
             '</String>', '<String name="u_String" valueReference="212" causality="input" variability="discrete">'
             '<Start value="u"/></String>', '<String name="y_String" valueReference="312" causality="output" '
             'variability="discrete"/>',
             '<Binary name="p_Binary" valueReference="113" causality="parameter" variability="fixed"><Start value="0a0b"/>'
             '</Binary>', '<Binary name="u_Binary" valueReference="213" causality="input" variability="discrete">'
             '<Start value="ff"/></Binary>', '<Binary name="y_Binary" valueReference="313" causality="output" '
             'variability="discrete"/>']
    outputs = "".join(f'<Output valueReference="{300 + i}" dependencies="{200 + i}"/>' for i in range(len(FMI3_TYPES) + 2))
    unknowns = "".join(f'<InitialUnknown valueReference="{300 + i}"/>' for i in range(len(FMI3_TYPES) + 2))
    items = "".join(f'<Item name="{n}" value="{v}"/>' for n, v in ITEMS)
    return f"""<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="3.0" modelName="EveryType" instantiationToken="{{every-type-3}}">
  <CoSimulation modelIdentifier="every_type3" canHandleVariableCommunicationStepSize="true"/>
  <TypeDefinitions><EnumerationType name="Colour">{items}</EnumerationType></TypeDefinitions>
  <DefaultExperiment startTime="0" stopTime="1" stepSize="0.1"/>
  <ModelVariables>
    {chr(10).join(rows)}
    {extra}
  </ModelVariables>
  <ModelStructure>{outputs}{unknowns}</ModelStructure>
</fmiModelDescription>
"""


def _fmi2_xml() -> str:
    rows, index = [], 0
    outputs, inputs = [], []
    for i, t in enumerate(FMI2_TYPES):
        kind = "continuous" if t == "Real" else "discrete"
        element = ('<Enumeration declaredType="Colour"' if t == "Enumeration" else f"<{t}")
        for prefix, vr, causality in (("p", 100, "parameter"), ("u", 200, "input"), ("y", 300, "output")):
            variability = "fixed" if causality == "parameter" else kind
            start = "" if causality == "output" else f' start="{_start(t)}"'
            rows.append(f'<ScalarVariable name="{prefix}_{t}" valueReference="{vr + i}" causality="{causality}" '
                        f'variability="{variability}">{element}{start}/></ScalarVariable>')
            index += 1
            if causality == "output":
                outputs.append(index)
            if causality == "input":
                inputs.append(index)
    items = "".join(f'<Item name="{n}" value="{v}"/>' for n, v in ITEMS)
    unknowns = "".join(f'<Unknown index="{k}" dependencies="{u}"/>' for k, u in zip(outputs, inputs))
    return f"""<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="EveryType" guid="{{every-type-2}}" variableNamingConvention="flat">
  <CoSimulation modelIdentifier="every_type2" canHandleVariableCommunicationStepSize="true"/>
  <TypeDefinitions><SimpleType name="Colour"><Enumeration>{items}</Enumeration></SimpleType></TypeDefinitions>
  <DefaultExperiment startTime="0" stopTime="1" stepSize="0.1"/>
  <ModelVariables>
    {chr(10).join(rows)}
  </ModelVariables>
  <ModelStructure><Outputs>{unknowns}</Outputs><InitialUnknowns>{unknowns}</InitialUnknowns></ModelStructure>
</fmiModelDescription>
"""


def every_type_fmu(dest: Path, fmi_version: int, extra_variables: str = "") -> Path:
    """The FMU of that FMI version built into dest (this machine's platform); extra_variables: FMI 3.0 variable
    elements added to its modelDescription.xml (an array, for a test of what the engine refuses)."""
    dest = Path(dest)
    identifier = f"every_type{fmi_version}"
    platform = "x86_64-linux" if fmi_version == 3 else "linux64"
    library = dest / f"{identifier}.so"
    subprocess.run(["cc", "-shared", "-fPIC", "-O1", "-std=c99", "-Wall", "-Werror", f"-I{HEADERS}",
                    str(HERE / f"{identifier}.c"), *([str(HERE / "refused3.c")] if fmi_version == 3 else []), "-o",
                    str(library)], check=True)
    fmu = dest / f"{identifier}{'_extra' if extra_variables else ''}.fmu"
    with zipfile.ZipFile(fmu, "w") as z:
        z.writestr("modelDescription.xml", _fmi3_xml(extra_variables) if fmi_version == 3 else _fmi2_xml())
        z.write(library, f"binaries/{platform}/{identifier}.so")
    return fmu

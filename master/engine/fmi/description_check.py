"""A modelDescription.xml's structure, checked before FMPy reads it. FMPy assumes a well-formed description: on a
malformed one it fails with its own internals ("'NoneType' object has no attribute 'startswith'", "list index out of
range"). Here each such problem is named as the standard names it, in one line (docs/bad_input.md)."""

from __future__ import annotations

import xml.etree.ElementTree as ET
import zipfile
import zlib
from pathlib import Path

DESCRIPTION = "modelDescription.xml"
MAX_DESCRIPTION = 256 * 2**20  # bytes: ten times the largest description a real FMU ships (a zip bomb is refused unread)
FMI2_TYPES = ("Real", "Integer", "Boolean", "String", "Enumeration")


def _read(path: Path) -> bytes | str:
    """The description's bytes, or why they cannot be read."""
    with zipfile.ZipFile(path) as z:
        try:
            info = z.getinfo(DESCRIPTION)
        except KeyError:
            return f"it holds no {DESCRIPTION}"
        if info.file_size > MAX_DESCRIPTION:
            return f"its {DESCRIPTION} declares {info.file_size} bytes, more than {MAX_DESCRIPTION} (refused unread)"
        try:
            with z.open(info) as member:
                data = member.read(MAX_DESCRIPTION + 1)
        except (zipfile.BadZipFile, zlib.error, OSError, EOFError, NotImplementedError) as err:
            return f"its {DESCRIPTION} cannot be read from the archive ({err})"
    if len(data) > MAX_DESCRIPTION:
        return f"its {DESCRIPTION} holds more than {MAX_DESCRIPTION} bytes"
    return data


def _variable_problem(index: int, variable: ET.Element, fmi3: bool) -> str | None:
    name = variable.get("name")
    if not name:
        return f"its variable {index} has no name"
    reference = variable.get("valueReference")
    if reference is None or not reference.strip().isdigit():
        return f"its variable {name} has no valueReference (an unsigned integer), got {reference!r}"
    if not fmi3:
        types = [c.tag for c in variable if c.tag in FMI2_TYPES]
        if len(types) != 1:
            return f"its variable {name} declares {len(types)} types of {', '.join(FMI2_TYPES)}; FMI 2.0 requires one"
    return None


def structure_problem(path: Path) -> str | None:
    """What makes the FMU's modelDescription.xml no FMI 2.0 or 3.0 description (None: FMPy can read it)."""
    data = _read(path)
    if isinstance(data, str):
        return data
    try:
        root = ET.fromstring(data)
    except ET.ParseError as err:
        return f"its {DESCRIPTION} is not well-formed XML ({err})"
    if root.tag != "fmiModelDescription":
        return f"its {DESCRIPTION}'s root element is <{root.tag[:40]}>, not <fmiModelDescription>"
    version = root.get("fmiVersion")
    if not version:
        return f"its {DESCRIPTION} declares no fmiVersion"
    fmi3 = version.startswith("3")
    for kind in ("CoSimulation", "ModelExchange", "ScheduledExecution"):
        interface = root.find(kind)
        if interface is not None and not interface.get("modelIdentifier"):
            return f"its <{kind}> declares no modelIdentifier"
    listed = root.find("ModelVariables")
    if listed is None:
        return f"its {DESCRIPTION} has no <ModelVariables>"
    variables = list(listed) if fmi3 else listed.findall("ScalarVariable")
    for index, variable in enumerate(variables, 1):
        if (problem := _variable_problem(index, variable, fmi3)) is not None:
            return problem
    structure = root.find("ModelStructure")
    if not fmi3 and structure is not None:  # FMI 2.0's structure names variables by their 1-based index
        for unknown in structure.iter("Unknown"):
            index = unknown.get("index", "")
            if not index.isdigit() or not 1 <= int(index) <= len(variables):
                return (f"its <ModelStructure> names variable index {index[:20]!r}, but it has {len(variables)} "
                        "variables (1-based)")
    return None

"""A malformed modelDescription.xml is refused in one line naming the problem as the standard does, never in FMPy's
internals (issue 62's leftover: "'NoneType' object has no attribute 'startswith'"). Generated: every attribute and
every element of a real description removed in turn, and hand-written breaks."""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import pytest
from tiltload.master.engine.errors import DescriptionError
from tiltload.master.engine.fmi.model_description import read_fmu

# what Python says about its own objects, never what a user can act on
INTERNALS = re.compile(r"NoneType|object has no attribute|index out of range|local variable|argument must be|"
                       r"not iterable|not subscriptable|KeyError|Traceback")


def _fmu(folder: Path, name: str, description: bytes) -> Path:
    path = folder / f"{name}.fmu"
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("modelDescription.xml", description)
    return path


def _outcome(path: Path) -> str | None:
    """None: read; else the refusal's line (a DescriptionError is the only way to refuse)."""
    try:
        read_fmu(path, "controller")
    except DescriptionError as err:
        return str(err)
    return None


def _mutants(root: ET.Element, variables: int = 8):
    """(label, description) with one attribute or one element of the description removed."""
    kept = list(root.find("ModelVariables"))[:variables]
    elements = [root, *(e for e in root if e.tag != "ModelVariables"), *kept]
    elements += [e for v in kept for e in v]
    elements += list(root.iter("Unknown"))[:variables]
    for at, element in enumerate(elements):
        for attribute in list(element.attrib):
            value = element.attrib.pop(attribute)
            yield f"{element.tag}#{at} without {attribute}", ET.tostring(root)
            element.attrib[attribute] = value
    for parent in [root, root.find("ModelVariables"), *kept]:
        for child in list(parent)[:variables]:
            index = list(parent).index(child)
            parent.remove(child)
            yield f"{parent.tag} without its {child.tag} {index}", ET.tostring(root)
            parent.insert(index, child)


@pytest.mark.parametrize("version", [2, 3])
def test_a_description_without_any_one_of_its_parts_is_read_or_refused_in_one_line(pipeline_fmus, tmp_path, version):
    source = pipeline_fmus["TiltloadController"]
    if version == 3:
        source = source.parent / "fmi3" / source.name
    with zipfile.ZipFile(source) as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
    refused, read, problems = 0, 0, []
    for n, (label, xml) in enumerate(_mutants(root)):
        line = _outcome(_fmu(tmp_path, f"m{n}", xml))
        if line is None:
            read += 1
            continue
        refused += 1
        if "\n" in line or INTERNALS.search(line) or not line.startswith("controller: "):
            problems.append(f"{label}: {line}")
    assert refused >= 10 and read + refused >= 60, (refused, read)
    assert not problems, "\n".join(problems[:20])


BROKEN = {
    "no fmiVersion": ('<fmiModelDescription modelName="a" guid="x"><CoSimulation modelIdentifier="a"/><ModelVariables/>'
                      '</fmiModelDescription>', "declares no fmiVersion"),
    "another root": ('<foo fmiVersion="2.0"/>', "root element is <foo>"),
    "no variables": ('<fmiModelDescription fmiVersion="2.0" modelName="a" guid="x"><CoSimulation modelIdentifier="a"/>'
                     '</fmiModelDescription>', "has no <ModelVariables>"),
    "a value reference no number": ('<fmiModelDescription fmiVersion="2.0" modelName="a" guid="x"><CoSimulation '
                                    'modelIdentifier="a"/><ModelVariables><ScalarVariable name="v" valueReference="x"><Real/>'
                                    '</ScalarVariable></ModelVariables></fmiModelDescription>', "variable v has no valueReference"),
    "a variable of no type": ('<fmiModelDescription fmiVersion="2.0" modelName="a" guid="x"><CoSimulation modelIdentifier="a"/>'
                              '<ModelVariables><ScalarVariable name="v" valueReference="1"/></ModelVariables>'
                              '</fmiModelDescription>', "variable v declares 0 types"),
    "an output index beyond the variables": (
        '<fmiModelDescription fmiVersion="2.0" modelName="a" guid="x"><CoSimulation modelIdentifier="a"/><ModelVariables>'
        '<ScalarVariable name="v" valueReference="1" causality="output"><Real/></ScalarVariable></ModelVariables>'
        '<ModelStructure><Outputs><Unknown index="7"/></Outputs></ModelStructure></fmiModelDescription>', "index '7'"),
    "no model identifier": ('<fmiModelDescription fmiVersion="3.0" modelName="a" instantiationToken="x"><CoSimulation/>'
                            '<ModelVariables/></fmiModelDescription>', "<CoSimulation> declares no modelIdentifier"),
    "not XML": ("<fmiModelDescription", "not well-formed XML"),
}


@pytest.mark.parametrize("label", BROKEN)
def test_each_broken_description_is_named(tmp_path, label):
    xml, says = BROKEN[label]
    line = _outcome(_fmu(tmp_path, "broken", xml.encode()))
    assert line is not None and says in line and not INTERNALS.search(line), line


def test_a_description_larger_than_any_real_one_is_refused_unread(tmp_path):
    from tiltload.master.engine.fmi.description_check import MAX_DESCRIPTION

    path = tmp_path / "bomb.fmu"
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:  # 257 MiB of spaces: about 250 KiB on disk
        with z.open("modelDescription.xml", "w", force_zip64=True) as member:
            chunk = b" " * 2**20
            for _ in range(MAX_DESCRIPTION // 2**20 + 1):
                member.write(chunk)
    assert path.stat().st_size < 2**21
    line = _outcome(path)
    assert line is not None and "refused unread" in line, line

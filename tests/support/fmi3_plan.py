"""The plan of the FMI 3.0 C host (hosts/fmi3_loop_host.c) for a system: its FMUs unpacked, their clocks and clocked
variables read from the model descriptions with ElementTree (not through the engine), parameters, connections."""

from __future__ import annotations

import xml.etree.ElementTree as ET
import zipfile
from fractions import Fraction
from pathlib import Path

from tiltload.master.engine import connections
from tiltload.master.engine.model_description import read_fmu


def host_plan(system, folder: Path, ticks: int, record: list[tuple[str, str]], platform: str = "x86_64-linux",
              native_path=str) -> Path:
    """Write folder/plan.txt: the system's FMUs (their binaries for platform, an FMI 3.0 platform tuple), ticks ticks,
    the (instance, variable) outputs to print after every tick; native_path: a path as the host sees it (wine: Z:\\)."""
    suffix = ".dll" if platform.endswith("-windows") else ".so"
    mds = {i.name: read_fmu(i.fmu, i.name) for i in system.instances}
    lines, vrs = [], {}
    tick = Fraction(repr(system.tick))
    for inst in system.instances:
        unpacked = folder / inst.name
        with zipfile.ZipFile(inst.fmu) as z:
            z.extractall(unpacked)
        root = ET.parse(unpacked / "modelDescription.xml").getroot()
        model = root.find("CoSimulation").get("modelIdentifier")
        lines.append(f"F {inst.name} {native_path(unpacked / 'binaries' / platform / (model + suffix))} "
                     f"{root.get('instantiationToken')}")
        elements = {e.get("name"): e for e in root.find("ModelVariables")}
        vrs[inst.name] = {n: e.get("valueReference") for n, e in elements.items()}
        for e in elements.values():
            if e.tag == "Clock":
                interval = Fraction(int(e.get("intervalCounter")), int(e.get("resolution"))) / tick
                assert interval.denominator == 1, e.get("name")
                lines.append(f"K {inst.name} {e.get('valueReference')} {interval.numerator} 0")
            elif e.get("clocks"):
                lines.append(f"V {inst.name} {e.get('valueReference')} {e.get('clocks')}")
        for key, value in inst.parameters.items():
            e = elements[key]
            code = {"Float64": "R", "Int32": "I", "Boolean": "B", "String": "S"}[e.tag]
            text = str(int(value)) if code in "IB" else (repr(float(value)) if code == "R" else str(value))
            lines.append(f"P {inst.name} {code} {e.get('valueReference')} {text}")
    for link in connections.resolve(system, mds):
        lines.append(f"C {link.source} {link.type[0]} {link.source_vr} {link.target} {link.target_vr}")
    lines.append(f"T {system.tick!r} {ticks}")
    lines += [f"O {inst} {vrs[inst][name]}" for inst, name in record]
    path = folder / "plan.txt"
    path.write_text("\n".join(lines) + "\n")
    return path

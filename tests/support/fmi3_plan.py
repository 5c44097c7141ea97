"""The plan of the FMI 3.0 C hosts (hosts/fmi3_loop_host.c, hosts/fmi3_se_host.c) for a system: its FMUs unpacked, their
clocks and clocked variables read from the model descriptions with ElementTree (not through the engine), parameters,
connections. A Scheduled Execution FMU (`S` line) may stand in for an instance of the system (scheduled): connections
are resolved on the system as it is, then found again by variable name in the stand-in's model description."""

from __future__ import annotations

import xml.etree.ElementTree as ET
import zipfile
from fractions import Fraction
from pathlib import Path

from tiltload.master.engine import connections
from tiltload.master.engine.fmi.model_description import read_fmu

INTERFACES = {"CoSimulation": "F", "ScheduledExecution": "S"}


def host_plan(system, folder: Path, ticks: int, record: list[tuple[str, str]], platform: str = "x86_64-linux",
              native_path=str, scheduled: dict[str, Path] | None = None) -> Path:
    """Write folder/plan.txt: the system's FMUs (their binaries for platform, an FMI 3.0 platform tuple), ticks ticks,
    the (instance, variable) outputs to print after every tick; native_path: a path as the host sees it (wine: Z:\\);
    scheduled: {instance: a Scheduled Execution FMU with the same variable names that replaces its FMU}."""
    suffix = ".dll" if platform.endswith("-windows") else ".so"
    scheduled = scheduled or {}
    mds = {i.name: read_fmu(i.fmu, i.name) for i in system.instances}
    lines, vrs = [], {}
    tick = Fraction(repr(system.tick))
    for inst in system.instances:
        unpacked = folder / inst.name
        with zipfile.ZipFile(scheduled.get(inst.name, inst.fmu)) as z:
            z.extractall(unpacked)
        root = ET.parse(unpacked / "modelDescription.xml").getroot()
        kind, interface = next((code, root.find(tag)) for tag, code in INTERFACES.items() if root.find(tag) is not None)
        model = interface.get("modelIdentifier")
        lines.append(f"{kind} {inst.name} {native_path(unpacked / 'binaries' / platform / (model + suffix))} "
                     f"{root.get('instantiationToken')}")
        elements = {e.get("name"): e for e in root.find("ModelVariables")}
        vrs[inst.name] = {n: e.get("valueReference") for n, e in elements.items()}
        for e in elements.values():
            if e.tag == "Clock":
                interval = Fraction(int(e.get("intervalCounter")), int(e.get("resolution"))) / tick
                assert interval.denominator == 1, e.get("name")
                lines.append(f"K {inst.name} {e.get('valueReference')} {interval.numerator} 0 {e.get('priority', '0')}")
            elif e.get("clocks"):
                lines.append(f"V {inst.name} {e.get('valueReference')} {e.get('clocks')}")
        if kind == "S":
            lines += [f"D {inst.name} {a} {b}" for a, b in sorted(_reads(root))]
        for key, value in inst.parameters.items():
            e = elements[key]
            code = {"Float64": "R", "Int32": "I", "Boolean": "B", "String": "S"}[e.tag]
            text = str(int(value)) if code in "IB" else (repr(float(value)) if code == "R" else str(value))
            lines.append(f"P {inst.name} {code} {e.get('valueReference')} {text}")
    for link in connections.resolve(system, mds):
        source = vrs[link.source][link.source_name] if link.source in scheduled else link.source_vr
        target = vrs[link.target][link.target_name] if link.target in scheduled else link.target_vr
        lines.append(f"C {link.source} {link.type[0]} {source} {link.target} {target}")
    lines.append(f"T {system.tick!r} {ticks}")
    lines += [f"O {inst} {vrs[inst][name]}" for inst, name in record]
    path = folder / "plan.txt"
    path.write_text("\n".join(lines) + "\n")
    return path


def _reads(root: ET.Element) -> set[tuple[str, str]]:
    """(consumer clock, producer clock) value references: a partition whose outputs depend on inputs clocked by
    another (ModelStructure; an output without `dependencies` depends on every input, the standard's default)."""
    clock_of = {e.get("valueReference"): e.get("clocks") for e in root.find("ModelVariables") if e.get("clocks")}
    inputs = [e.get("valueReference") for e in root.find("ModelVariables")
              if e.get("causality") == "input" and e.tag != "Clock"]
    out = set()
    for o in root.find("ModelStructure").iter("Output"):
        consumer = clock_of.get(o.get("valueReference"))
        deps = o.get("dependencies")
        for vr in (deps.split() if deps is not None else inputs):
            producer = clock_of.get(vr)
            if consumer and producer and producer != consumer:
                out.add((consumer, producer))
    return out

"""Resolve and check a system's connections against the FMUs' model descriptions, before any step.

Explicit connections first; then, if auto_connect, every still-unconnected input takes the
output of the same name when exactly one other instance has it. Every problem is reported
with the names involved: unknown variable, wrong causality, type mismatch, ambiguous name,
an input left unconnected without a start value.
"""

from __future__ import annotations

from dataclasses import dataclass

from .errors import DescriptionError
from .fmi.model_description import FMI_TYPES, enumeration_items, fmi_type
from .fmi.slave import TYPES
from .system import System


@dataclass(frozen=True)
class Link:
    source: str  # instance
    source_vr: int
    target: str
    target_vr: int
    type: str  # the target's carrier (the engine's array its values are set from: Real, Integer, Boolean), or String, Binary
    delay: int
    source_name: str  # the variables' names
    target_name: str
    source_type: str  # the source's carrier: the target's, or Integer into a Real target (CONVERSIONS)

    @property
    def label(self) -> str:
        return f"{self.source}.{self.source_name} -> {self.target}.{self.target_name}"


def _var(mds, inst, name):
    for v in mds[inst].modelVariables:
        if v.name == name:
            return v
    raise DescriptionError(f"{inst} has no variable '{name}'")


# The conversions between carriers a connection's gather makes (source carrier, target carrier): the one rule, applied
# by the tick loop's gather (tl_loop.c) and the initial propagation (execution.py). Every lossless conversion between
# two types of different carriers (FmiType.holds) is one of these: whole numbers into a double, exact.
CONVERSIONS = {("Integer", "Real")}
TEXTS = ("String", "Binary")  # connected as themselves only, set through the loop's callback (texts.py)


def check_types(label: str, src, dst) -> None:
    """A connection carries its source's type into its target's: the same type, or a conversion that loses nothing
    (FmiType.holds; across the engine's arrays one of CONVERSIONS); anything else refused in one line naming both ends."""
    s, d = fmi_type(src), fmi_type(dst)
    ks, kd = FMI_TYPES.get(s), FMI_TYPES.get(d)
    if s in TEXTS or d in TEXTS:
        if s != d:
            raise DescriptionError(f"connection {label}: {s} -> {d}: a {s if s in TEXTS else d} connects only to a "
                                   f"{s if s in TEXTS else d}")
        return
    if ks is None or kd is None or ks.carrier is None or kd.carrier is None:
        raise DescriptionError(f"connection {label}: {s} -> {d}: {s if ks is None or ks.carrier is None else d} "
                               "connections are not supported (numbers, Booleans, Enumerations, Strings and Binaries are)")
    if "Enumeration" in (s, d):
        if s != d or enumeration_items(src) != enumeration_items(dst):
            raise DescriptionError(f"connection {label}: {s} -> {d}: an Enumeration connects only to an Enumeration of "
                                   "the same items")
        return
    if not kd.holds(ks):
        raise DescriptionError(f"connection {label}: {s} -> {d} would lose values: a lossy conversion is refused")
    if ks.carrier != kd.carrier and (ks.carrier, kd.carrier) not in CONVERSIONS:  # none today: holds refuses them
        raise DescriptionError(f"connection {label}: {s} -> {d} is lossless but not supported (the engine carries "
                               f"{s} with its {ks.carrier} values, {d} with its {kd.carrier} values)")


def resolve(system: System, mds: dict) -> list[Link]:
    links: list[Link] = []
    taken: set[tuple[str, str]] = set()
    for c in system.connections:
        si, sv = c.source.split(".", 1)
        ti, tv = c.target.split(".", 1)
        src, dst = _var(mds, si, sv), _var(mds, ti, tv)
        if src.causality != "output":
            raise DescriptionError(f"connection {c.source} -> {c.target}: {c.source} is a {src.causality}, not an output")
        if dst.causality != "input":
            raise DescriptionError(f"connection {c.source} -> {c.target}: {c.target} is a {dst.causality}, not an input")
        check_types(f"{c.source} -> {c.target}", src, dst)
        if (ti, tv) in taken:
            raise DescriptionError(f"{c.target} is connected twice")
        taken.add((ti, tv))
        links.append(Link(si, src.valueReference, ti, dst.valueReference, dst.type, c.delay, sv, tv, src.type))
    outputs: dict[str, list] = {}
    for inst in system.instances:
        for v in mds[inst.name].modelVariables:
            if v.causality == "output":
                outputs.setdefault(v.name, []).append((inst.name, v))
    for inst in system.instances:
        for v in mds[inst.name].modelVariables:
            if v.causality != "input" or (inst.name, v.name) in taken:
                continue
            candidates = [(i, o) for i, o in outputs.get(v.name, []) if i != inst.name] if system.auto_connect else []
            if len(candidates) > 1:
                raise DescriptionError(f"{inst.name}.{v.name}: ambiguous, outputs of that name in "
                                       f"{', '.join(i for i, _ in candidates)}; connect it explicitly")
            if candidates:
                si, o = candidates[0]
                check_types(f"{si}.{o.name} -> {inst.name}.{v.name}", o, v)
                links.append(Link(si, o.valueReference, inst.name, v.valueReference, v.type, 0, o.name, v.name, o.type))
            elif v.start is None:
                raise DescriptionError(f"{inst.name}.{v.name} is an input with no connection and no start value")
    for link in links:
        if link.type not in (*TYPES, *TEXTS):
            raise DescriptionError(f"{link.label}: {link.type} connections are not supported")
    return links


def unconnected(system: System, mds: dict, links: list[Link]) -> list[str]:
    """Inputs no connection feeds, as "instance.name = value": they hold their start value, or the value
    the system's parameters give them, for the whole run."""
    fed = {(link.target, link.type, link.target_vr) for link in links}
    out = []
    for inst in system.instances:
        for v in mds[inst.name].modelVariables:
            if v.causality == "input" and (inst.name, v.type, v.valueReference) not in fed:
                value = inst.parameters.get(v.name, v.start)
                out.append(f"{inst.name}.{v.name} = {str(value).lower() if v.type == 'Boolean' else value}")
    return out

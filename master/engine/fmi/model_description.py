"""What the engine reads of an FMU before loading it: its model description, and values checked against it.

FMI 2.0 and FMI 3.0 co-simulation FMUs are read into one view, the one the engine works with: FMPy's model
description; for an FMI 3.0 FMU, a view of it (Fmi3Description) where the Float64 and Int32 variables take the
engine's type names Real and Integer (the FMI 3.0 names stay in `fmi3_types`), and the Clock variables are not
variables to connect but the FMU's schedule, `clocks` (read here from the XML: FMPy does not parse intervals).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
import zipfile
from dataclasses import dataclass
from pathlib import Path

from fmpy import read_model_description

from ..errors import DescriptionError

ENGINE_TYPE = {"Float64": "Real", "Int32": "Integer", "Boolean": "Boolean", "String": "String"}
FMI3_TYPE = {engine: fmi3 for fmi3, engine in ENGINE_TYPE.items()}
PERIODIC = ("constant", "fixed", "tunable")  # time-based clocks whose interval the model description gives


@dataclass(frozen=True)
class Clock:
    """A periodic input clock of an FMI 3.0 FMU: the importer activates it at shift, shift + interval, ..."""

    name: str
    value_reference: int
    interval: float  # s
    shift: float  # s
    variables: tuple[str, ...]  # the variables it clocks
    priority: int | None = None  # Scheduled Execution: its partition's priority (smaller runs first at one instant)


class Fmi3Description:
    """FMPy's description of an FMI 3.0 FMU in the engine's terms; every other attribute is FMPy's."""

    def __init__(self, md, clocks: tuple[Clock, ...], fmi3_types: dict[str, str]) -> None:
        self._md = md
        self.clocks = clocks
        self.fmi3_types = fmi3_types  # variable name -> its FMI 3.0 type (Float64, Int32, Boolean, String, ...)

    def __getattr__(self, name):
        return getattr(self._md, name)


def fmi_version(md) -> int:
    return 3 if str(md.fmiVersion).startswith("3") else 2


def is_scheduled(md) -> bool:
    """An FMI 3.0 Scheduled Execution FMU (no co-simulation interface): the master schedules its model partitions."""
    return fmi_version(md) == 3 and md.coSimulation is None and getattr(md, "scheduledExecution", None) is not None


def read_fmu(path: Path, instance: str):
    """Model description of a co-simulation FMU (FMI 2.0 or 3.0), or a DescriptionError saying what the file is not."""
    from ..user_files import UserFileError, regular_file

    path = Path(path)
    try:
        regular_file(path, "FMU file")
    except UserFileError as err:
        raise DescriptionError(f"{instance}: {err}") from None
    if not zipfile.is_zipfile(path):
        raise DescriptionError(f"{instance}: {path} is not an FMU (not a zip archive)")
    from .description_check import structure_problem

    if (problem := structure_problem(path)) is not None:  # named as the standard names it, not in FMPy's internals
        raise DescriptionError(f"{instance}: {path} is not a valid FMU: {problem}")
    try:
        md = read_model_description(str(path), validate=False)
    except Exception as err:  # fmpy raises various types for a broken modelDescription.xml
        raise DescriptionError(f"{instance}: {path} is not a valid FMU ({err})") from None
    if md.fmiVersion != "2.0" and fmi_version(md) != 3:
        raise DescriptionError(f"{instance}: {path} is FMI {md.fmiVersion}; FMI 2.0 and 3.0 co-simulation are supported")
    if not isinstance(md.guid, str) or not md.guid.strip():  # the instantiate call passes it back: required by both standards
        attribute = "instantiationToken" if fmi_version(md) == 3 else "guid"
        raise DescriptionError(f"{instance}: {path} declares no {attribute} in its modelDescription.xml "
                               f"(FMI {md.fmiVersion} requires one)")
    if md.coSimulation is None and not is_scheduled(md):
        raise DescriptionError(f"{instance}: {path} is a model-exchange-only FMU; a co-simulation or an FMI 3.0 Scheduled "
                               "Execution FMU is needed")
    return _engine_view(md, path, instance) if fmi_version(md) == 3 else md


def _engine_view(md, path: Path, instance: str) -> Fmi3Description:
    """An FMI 3.0 description in the engine's terms: type names, clocks apart from the variables."""
    with zipfile.ZipFile(path) as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
    declared = {e.get("name"): e for e in root.iter("Clock")}
    clocked: dict[str, list[str]] = {}
    for v in md.modelVariables:
        for k in v.clocks or ():
            clocked.setdefault(k.name, []).append(v.name)
    clocks = []
    for v in md.modelVariables:
        if v.type != "Clock":
            continue
        e = declared[v.name]
        kind = e.get("intervalVariability")
        if v.causality != "input" or kind not in PERIODIC or e.get("intervalDecimal") is None:
            raise DescriptionError(f"{instance}: clock {v.name} is a{'n' if v.causality[0] in 'aeiou' else ''} "
                                   f"{v.causality} clock with intervalVariability {kind!r}; only periodic input clocks "
                                   "(constant, fixed or tunable, with an intervalDecimal) are supported")
        priority = e.get("priority")
        clocks.append(Clock(v.name, v.valueReference, float(e.get("intervalDecimal")), float(e.get("shiftDecimal", "0")),
                            tuple(clocked.get(v.name, ())), None if priority is None else int(priority)))
    if is_scheduled(md) and any(k.priority is None for k in clocks):
        raise DescriptionError(f"{instance}: {path} is a Scheduled Execution FMU whose clocks do not all declare a priority "
                               "(FMI 3.0 requires one per clock)")
    if clocks and not is_scheduled(md) and not md.coSimulation.hasEventMode:
        raise DescriptionError(f"{instance}: {path} has clocks but hasEventMode is false")
    md.modelVariables = [v for v in md.modelVariables if v.type != "Clock"]
    fmi3_types = {v.name: v.type for v in md.modelVariables}
    for v in md.modelVariables:
        v.type = ENGINE_TYPE.get(v.type, v.type)
    return Fmi3Description(md, tuple(clocks), fmi3_types)


def clocks_of(md) -> tuple[Clock, ...]:
    return getattr(md, "clocks", ())


def clock_ticks(md, tick: float, instance: str) -> dict[str, tuple[int, int]]:
    """{clock: (interval, shift) in ticks}, or a DescriptionError for a clock off the tick grid."""
    out = {}
    for k in clocks_of(md):
        n, s = round(k.interval / tick), round(k.shift / tick)
        if n < 1 or abs(n * tick - k.interval) > 1e-9 * k.interval or abs(s * tick - k.shift) > 1e-9 * max(k.interval, tick):
            raise DescriptionError(f"{instance}: clock {k.name} (interval {k.interval:g} s, shift {k.shift:g} s) is not on "
                                   f"the {tick:g} s tick: its interval and shift must be whole numbers of ticks")
        out[k.name] = (n, s)
    return out


def steps_every(spec, md, tick: float) -> int:
    """Ticks between an instance's steps: its period, or for an FMU with clocks (which replace the period) the
    greatest common divisor of the clocks' intervals and shifts, so it steps at every tick one of them is due.
    Checks the FMI version the system description names, if it names one."""
    version = fmi_version(md)
    if getattr(spec, "fmi", None) not in (None, version):
        raise DescriptionError(f"{spec.name}: the system description says FMI {spec.fmi}, but {Path(spec.fmu).name} is "
                               f"FMI {version}.0")
    ticks = clock_ticks(md, tick, spec.name)
    if not ticks:
        return 1 if spec.period is None else round(spec.period / tick)
    if spec.period is not None:
        raise DescriptionError(f"{spec.name}: {Path(spec.fmu).name} has clocks ({', '.join(ticks)}), which replace "
                               "period: remove the period")
    return math.gcd(*(n for n, _ in ticks.values()), *(s for _, s in ticks.values()))


def checked_value(instance: str, v, key: str, value):
    """A parameter (or unconnected input) value converted to the variable's FMI type, or a DescriptionError
    naming it: unknown or unsettable variable, wrong kind, non-finite, outside the declared min/max or int32."""
    if v is None:
        raise DescriptionError(f"{instance} has no variable '{key}' to set")
    if v.causality not in ("parameter", "input") or v.variability == "constant":
        raise DescriptionError(f"{instance}.{key} is a {v.causality} ({v.variability}); only parameters and inputs can be set")
    where = f"{instance}.{key} = {value!r}"
    if v.type in ("Real", "Integer"):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise DescriptionError(f"{where}: must be a number")
        if not math.isfinite(value):
            raise DescriptionError(f"{where}: must be finite")
        if v.type == "Integer":
            if value != int(value) or not -2**31 <= value < 2**31:
                raise DescriptionError(f"{where}: must be a whole number that fits 32 bits")
            value = int(value)
        else:
            value = float(value)
        lo, hi = (None if b is None else float(b) for b in (v.min, v.max))
        if (lo is not None and value < lo) or (hi is not None and value > hi):
            raise DescriptionError(f"{where}: outside its declared range [{lo if lo is not None else '-inf'}, "
                                   f"{hi if hi is not None else 'inf'}]")
        return value
    if v.type == "Boolean":
        if isinstance(value, bool) or value in (0, 1):
            return bool(value)
        raise DescriptionError(f"{where}: must be true or false")
    if v.type != "String":
        raise DescriptionError(f"{where}: {v.type} variables cannot be set by the engine")
    return str(value)

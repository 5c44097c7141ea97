"""What the engine reads of an FMU before loading it: its model description, and values checked against it.

FMI 2.0 and FMI 3.0 co-simulation FMUs are read into one view, the one the engine works with: FMPy's model
description where each variable's `type` is the engine's array that carries it (Real, Integer, Boolean: FMI_TYPES,
the one table of the value types) and its standard type is `fmi_type(v)`; for an FMI 3.0 FMU, a view of it
(Fmi3Description) where the Clock variables are not variables to connect but the FMU's schedule, `clocks` (read
here from the XML: FMPy does not parse intervals). Array variables (FMI 3.0 dimensions) are refused when read.
"""

from __future__ import annotations

import ctypes
import math
import weakref
import xml.etree.ElementTree as ET
import zipfile
from dataclasses import dataclass
from pathlib import Path

from fmpy import read_model_description

from ..errors import DescriptionError


@dataclass(frozen=True)
class FmiType:
    """One FMI value type: the engine's array that carries it between FMUs and into the log (None: not carried), its
    C type in FMI 3.0's get and set functions, and the whole numbers it holds (None: not an integer type)."""

    carrier: str | None
    c_type: object
    bounds: tuple[int, int] | None = None

    def holds(self, other: FmiType) -> bool:
        """Does every value of other convert to this type without loss (a connection other -> self)?"""
        if None in (self.carrier, other.carrier) or "Boolean" in (self.carrier, other.carrier):
            return self is other
        if self.bounds is not None:  # an integer takes the integers within its range
            return other.bounds is not None and self.bounds[0] <= other.bounds[0] and other.bounds[1] <= self.bounds[1]
        if other.bounds is not None:  # a float takes the integers its mantissa holds exactly
            digits = 53 if self.c_type is ctypes.c_double else 24
            return -2**digits <= other.bounds[0] and other.bounds[1] <= 2**digits
        return ctypes.sizeof(self.c_type) >= ctypes.sizeof(other.c_type)


# The value types by their FMI 3.0 names (FMI 2.0's: FMI2_TYPE). A double carries the 64-bit integers and UInt32: exact
# within +-2^53 (a value beyond is refused when read, fmi3.py); Enumerations travel as whole numbers (FMI 3.0 gets and
# sets them as Int64, FMI 2.0 as Integer).
FMI_TYPES = {
    "Float64": FmiType("Real", ctypes.c_double),
    "Float32": FmiType("Real", ctypes.c_float),
    "Int8": FmiType("Integer", ctypes.c_int8, (-2**7, 2**7 - 1)),
    "UInt8": FmiType("Integer", ctypes.c_uint8, (0, 2**8 - 1)),
    "Int16": FmiType("Integer", ctypes.c_int16, (-2**15, 2**15 - 1)),
    "UInt16": FmiType("Integer", ctypes.c_uint16, (0, 2**16 - 1)),
    "Int32": FmiType("Integer", ctypes.c_int32, (-2**31, 2**31 - 1)),
    "UInt32": FmiType("Real", ctypes.c_uint32, (0, 2**32 - 1)),
    "Int64": FmiType("Real", ctypes.c_int64, (-2**63, 2**63 - 1)),
    "UInt64": FmiType("Real", ctypes.c_uint64, (0, 2**64 - 1)),
    "Boolean": FmiType("Boolean", ctypes.c_bool),
    "Enumeration": FmiType("Integer", ctypes.c_int64, (-2**31, 2**31 - 1)),
    "String": FmiType(None, ctypes.c_char_p),
    "Binary": FmiType(None, ctypes.c_void_p),
}
FMI2_TYPE = {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean", "String": "String", "Enumeration": "Enumeration"}
EXACT = 2**53  # a double holds every whole number up to this


_FMI_TYPE: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # variable -> its standard type (FMPy's are slotted)


def fmi_type(v) -> str:
    """A variable's type as its standard names it in FMI 3.0 terms (Float64, Int8, Enumeration, ...)."""
    try:
        known = _FMI_TYPE.get(v)
    except TypeError:  # a variable no model description was read for (a test's stand-in)
        known = None
    return known or FMI2_TYPE.get(v.type, v.type)


def enumeration_items(v) -> list[tuple[str, int]]:
    """An Enumeration variable's items (name, value), as its declared type lists them."""
    declared = getattr(v, "declaredType", None)
    return [(item.name, int(item.value)) for item in getattr(declared, "items", None) or ()]


def _carried(md, instance: str, path: Path) -> None:
    """Each variable's type becomes the engine's carrier, its standard type kept for fmi_type(v); arrays refused."""
    for v in md.modelVariables:
        name = v.type if fmi_version(md) == 3 else FMI2_TYPE.get(v.type, v.type)
        if getattr(v, "dimensions", None) or getattr(v, "dimensionValueReferences", None):
            raise DescriptionError(f"{instance}: {path.name} has the array variable {v.name} ({name} with dimensions): "
                                   "array variables are not supported; only scalar variables can be set, connected "
                                   "and logged")
        if name == "Enumeration" and any(not -2**31 <= value < 2**31 for _, value in enumeration_items(v)):
            raise DescriptionError(f"{instance}: enumeration {v.name} has items beyond 32 bits; not supported")
        _FMI_TYPE[v] = name
        kind = FMI_TYPES.get(name)
        if kind is not None and kind.carrier is not None:
            v.type = kind.carrier
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

    def __init__(self, md, clocks: tuple[Clock, ...]) -> None:
        self._md = md
        self.clocks = clocks

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
    if fmi_version(md) == 3:
        return _engine_view(md, path, instance)
    _carried(md, instance, path)
    return md


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
    _carried(md, instance, path)
    return Fmi3Description(md, tuple(clocks))


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
    naming it: unknown or unsettable variable, wrong kind, non-finite, outside its type's or its declared range, not
    one of an Enumeration's items."""
    if v is None:
        raise DescriptionError(f"{instance} has no variable '{key}' to set")
    if v.causality not in ("parameter", "input") or v.variability == "constant":
        raise DescriptionError(f"{instance}.{key} is a {v.causality} ({v.variability}); only parameters and inputs can be set")
    where = f"{instance}.{key} = {value!r}"
    name = fmi_type(v)
    kind = FMI_TYPES.get(name)
    if name == "Enumeration" and isinstance(value, str):  # an item by its name (SSV writes them so)
        items = dict(enumeration_items(v))
        if value.strip() not in items:
            raise DescriptionError(f"{where}: not one of its items ({', '.join(f'{n}={x}' for n, x in items.items())})")
        value = items[value.strip()]
    if kind is not None and kind.carrier in ("Real", "Integer"):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise DescriptionError(f"{where}: must be a number")
        if not math.isfinite(value):
            raise DescriptionError(f"{where}: must be finite")
        if kind.bounds is not None:
            lo, hi = kind.bounds
            if value != int(value) or not lo <= value <= hi:
                raise DescriptionError(f"{where}: must be a whole number in {name}'s range [{lo}, {hi}]")
            value = int(value)
            items = enumeration_items(v) if name == "Enumeration" else []
            if items and value not in {x for _, x in items}:
                raise DescriptionError(f"{where}: not one of its items ({', '.join(f'{n}={x}' for n, x in items)})")
        else:
            value = float(value)
            if name == "Float32" and abs(value) > 3.4028234663852886e38:
                raise DescriptionError(f"{where}: beyond Float32's range")
        lo, hi = (None if b is None else float(b) for b in (v.min, v.max))
        if (lo is not None and value < lo) or (hi is not None and value > hi):
            raise DescriptionError(f"{where}: outside its declared range [{lo if lo is not None else '-inf'}, "
                                   f"{hi if hi is not None else 'inf'}]")
        return value
    if name == "Boolean":
        if isinstance(value, bool) or value in (0, 1):
            return bool(value)
        raise DescriptionError(f"{where}: must be true or false")
    if name == "Binary":
        if isinstance(value, (bytes, bytearray)):
            return bytes(value)
        try:  # a Binary value given as text is its bytes in hexadecimal
            return bytes.fromhex(str(value))
        except ValueError:
            raise DescriptionError(f"{where}: a Binary value is bytes in hexadecimal (\"0a1b\")") from None
    if name != "String":
        raise DescriptionError(f"{where}: {name} variables cannot be set by the engine")
    return str(value)

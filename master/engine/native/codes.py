"""The codes the tick loop shares with Python, as IntEnums read from the one table that declares them: tl_codes.h,
whose X-macro tables the C compiler turns into the kernel's enums. Nothing here repeats a value: a code added,
changed or renumbered there is the same here on the next import.

The format read is the header's own rule: a table is `#define TL_<TABLE>(X) \\` followed by one `X(TL_NAME, value)`
entry a line (a comment after it, or a comment line, allowed). Anything else inside a table raises at import.
"""

from __future__ import annotations

import re
from enum import IntEnum
from pathlib import Path

HEADER = Path(__file__).with_name("tl_codes.h")

_TABLE = re.compile(r"^#define (TL_\w+)\(X\) \\$")
_ENTRY = re.compile(r"^\s*X\((TL_\w+), (-?\d+)\)\s*(?:/\*.*\*/)?\s*(\\?)$")
_COMMENT = re.compile(r"^\s*/\*.*\*/\s*\\$")


class CodesError(RuntimeError):
    """tl_codes.h does not follow the format this module reads."""


def read_tables(text: str, where: str = "tl_codes.h") -> dict[str, list[tuple[str, int]]]:
    """Every X-macro table of the header's text: its name -> [(entry, value)] in order."""
    tables: dict[str, list[tuple[str, int]]] = {}
    lines = text.splitlines()
    i = 0
    while i < len(lines):
        head = _TABLE.match(lines[i])
        i += 1
        if head is None:
            continue
        entries, more = tables.setdefault(head.group(1), []), True
        while more:
            if i == len(lines):
                raise CodesError(f"{where}: table {head.group(1)} runs past the end of the file")
            line = lines[i]
            i += 1
            if _COMMENT.match(line):
                continue
            entry = _ENTRY.match(line)
            if entry is None:
                raise CodesError(f"{where} line {i}: not an X(TL_NAME, value) entry of {head.group(1)}: {line.strip()!r}")
            entries.append((entry.group(1), int(entry.group(2))))
            more = entry.group(3) == "\\"
    return tables


def enum_of(tables: dict, table: str, name: str, prefix: str = "TL_") -> type[IntEnum]:
    """The table as an IntEnum: each entry's name without the prefix (which every entry must have), its value.
    CodesError: no such table, a name without the prefix, two entries with one value."""
    if table not in tables:
        raise CodesError(f"tl_codes.h has no table {table}")
    members = []
    for entry, value in tables[table]:
        if not entry.startswith(prefix):
            raise CodesError(f"tl_codes.h: {table}'s entry {entry} does not start with {prefix}")
        members.append((entry.removeprefix(prefix), value))
    values = [v for _, v in members]
    if len(set(values)) != len(values):
        raise CodesError(f"tl_codes.h: {table} gives two entries one value")
    return IntEnum(name, members, module=__name__)


_TABLES = read_tables(HEADER.read_text())

Dimension = enum_of(_TABLES, "TL_DIMENSIONS", "Dimension")  # the plan's fixed array lengths
ValueType = enum_of(_TABLES, "TL_VALUE_TYPES", "ValueType")  # REAL, INTEGER, BOOLEAN: the per-type arrays' index
Side = enum_of(_TABLES, "TL_SIDES", "Side")  # INPUTS, OUTPUTS: where a fault or the hook callback acts
Profile = enum_of(_TABLES, "TL_PROFILES", "Profile", "TL_PROFILE_")  # OFF, WALL, CPU
FaultAction = enum_of(_TABLES, "TL_FAULT_ACTIONS", "FaultAction")  # OVERRIDE ... DROPOUT
PartKind = enum_of(_TABLES, "TL_PART_KINDS", "PartKind")  # CONTINUOUS, DISCRETE (0..: a clock's index)
ErrorKind = enum_of(_TABLES, "TL_ERROR_KINDS", "ErrorKind", "TL_ERROR_")  # why a call of tl_run stopped early


def value_type(typ: str) -> ValueType:
    """The kernel's code of one of the engine's value types ("Real", "Integer", "Boolean": slave.TYPES)."""
    return ValueType[typ.upper()]


def type_name(code: int) -> str:
    """The engine's name of the kernel's value type code."""
    return ValueType(code).name.capitalize()
LinkFailure = enum_of(_TABLES, "TL_LINK_FAILURES", "LinkFailure", "TL_LINK_")  # ENDED, TIMEOUT, CORRUPT
LinkCorruption = enum_of(_TABLES, "TL_LINK_CORRUPTIONS", "LinkCorruption", "TL_CORRUPT_")  # SEQUENCE ... TIME

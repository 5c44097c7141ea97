"""A scenario's files (trajectories, wind) as tables and documents: what their content means, not how it is read.

The reading (size limits, YAML without aliases, numbers finite and bounded as they are parsed) is the master's one
input layer (master/engine/user_files.py); it comes in as a Reader, since an FMU package does not import the master.
Every problem is a ScenarioFileError whose message is one line naming the file and, where it helps, the line.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Protocol


class ScenarioFileError(ValueError):
    """A trajectory or wind file that cannot be used as given; the message is one line naming the file and the problem."""


class Reader(Protocol):
    """How a scenario file is read (master.app.inputs.READER)."""

    def table(self, path: Path) -> list[tuple[int, list[str]]]:
        """A CSV file: (line number, cells) of each line that is neither blank nor a # comment."""

    def document(self, path: Path) -> object:
        """A JSON (.json) or YAML (.yaml, .yml) document."""


def read_structured(path: Path, read: Reader):
    """A JSON (.json) or YAML (.yaml, .yml) document."""
    path = Path(path)
    if path.suffix.lower() not in (".json", ".yaml", ".yml"):
        raise ScenarioFileError(f"{path}: a scenario file is .csv, .json, .yaml or .yml")
    return read.document(path)


def read_rows(path: Path, fields: tuple[str, ...], required: tuple[str, ...], read: Reader) -> tuple[list[dict], list[str]]:
    """A CSV table whose header names its columns (among fields, with every one of required): the rows as
    {column: number} without the empty cells, and "line N" for each. Blank lines and lines starting with # are skipped."""
    path = Path(path)
    lines = read.table(path)
    if not lines:
        raise ScenarioFileError(f"{path}: empty: the first line must be a header such as {','.join(required)}")
    first, header = lines[0][0], [h.strip() for h in lines[0][1]]
    unknown = [h for h in header if h not in fields]
    if unknown:
        raise ScenarioFileError(f"{path}: line {first}: unknown column {', '.join(repr(h[:40]) for h in unknown[:3])} "
                                f"(the columns are {','.join(fields)}; the first line is the header)")
    missing = [f for f in required if f not in header]
    if missing:
        raise ScenarioFileError(f"{path}: line {first}: missing column {', '.join(missing)} (the header needs {','.join(required)})")
    repeated = sorted({h for h in header if header.count(h) > 1})
    if repeated:
        raise ScenarioFileError(f"{path}: line {first}: column {', '.join(repeated)} appears twice")
    rows, where = [], []
    for number, cells in lines[1:]:
        if len(cells) != len(header):
            raise ScenarioFileError(f"{path}: line {number}: {len(cells)} values for the header's {len(header)} columns")
        row = {}
        for name, cell in zip(header, cells):
            cell = cell.strip()
            if not cell:
                if name in required:
                    raise ScenarioFileError(f"{path}: line {number}: {name} is empty")
                continue
            try:
                row[name] = float(cell)
            except ValueError:
                raise ScenarioFileError(f"{path}: line {number}: {name} = {cell[:40]!r} is not a number") from None
            if math.isinf(row[name]) and "inf" not in cell.lower():
                raise ScenarioFileError(f"{path}: line {number}: {name} = {cell[:24]}... ({len(cell)} characters) is beyond a "
                                        "double's range")
        rows.append(row)
        where.append(f"line {number}")
    return rows, where

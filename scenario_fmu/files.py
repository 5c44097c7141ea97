"""Reading a scenario's files (trajectories, wind): CSV tables with a header, JSON and YAML documents.

Every problem is a ScenarioFileError whose message is one line naming the file and, where it helps, the line.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path


class ScenarioFileError(ValueError):
    """A trajectory or wind file that cannot be used as given; the message is one line naming the file and the problem."""


def read_structured(path: Path):
    """A JSON (.json) or YAML (.yaml, .yml) document."""
    path = Path(path)
    text = _text(path)
    suffix = path.suffix.lower()
    try:
        if suffix == ".json":
            return json.loads(text)
        if suffix in (".yaml", ".yml"):
            import yaml

            return yaml.safe_load(text)
    except json.JSONDecodeError as err:
        raise ScenarioFileError(f"{path}: not valid JSON: {err}") from None
    except Exception as err:  # yaml's errors
        first = str(err).splitlines()[0] if str(err) else type(err).__name__
        raise ScenarioFileError(f"{path}: not valid YAML: {first}") from None
    raise ScenarioFileError(f"{path}: a scenario file is .csv, .json, .yaml or .yml")


def read_rows(path: Path, fields: tuple[str, ...], required: tuple[str, ...]) -> tuple[list[dict], list[str]]:
    """A CSV table whose header names its columns (among fields, with every one of required): the rows as
    {column: number} without the empty cells, and "line N" for each. Blank lines and lines starting with # are skipped."""
    path = Path(path)
    lines = [(n, line) for n, line in enumerate(_text(path).splitlines(), start=1) if line.strip() and not line.lstrip().startswith("#")]
    if not lines:
        raise ScenarioFileError(f"{path}: empty: the first line must be a header such as {','.join(required)}")
    reader = csv.reader([line for _, line in lines])
    header = [h.strip() for h in next(reader)]
    unknown = [h for h in header if h not in fields]
    if unknown:
        raise ScenarioFileError(f"{path}: line {lines[0][0]}: unknown column {', '.join(repr(h) for h in unknown)} "
                                f"(the columns are {','.join(fields)}; the first line is the header)")
    missing = [f for f in required if f not in header]
    if missing:
        raise ScenarioFileError(f"{path}: line {lines[0][0]}: missing column {', '.join(missing)} (the header needs {','.join(required)})")
    repeated = sorted({h for h in header if header.count(h) > 1})
    if repeated:
        raise ScenarioFileError(f"{path}: line {lines[0][0]}: column {', '.join(repeated)} appears twice")
    rows, where = [], []
    for (number, _), cells in zip(lines[1:], reader):
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
                raise ScenarioFileError(f"{path}: line {number}: {name} = {cell!r} is not a number") from None
        rows.append(row)
        where.append(f"line {number}")
    return rows, where


def _text(path: Path) -> str:
    if not path.is_file():
        raise ScenarioFileError(f"{path}: no such file")
    try:
        return path.read_text()
    except UnicodeDecodeError:
        raise ScenarioFileError(f"{path}: not a text file") from None
    except OSError as err:
        raise ScenarioFileError(f"{path}: cannot read it: {err.strerror or err}") from None

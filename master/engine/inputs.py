"""Input files: a table of one FMU instance's inputs over time (CSV or Parquet), as FMPy's --input-file.

The first column is the time (s, non-decreasing); every other column names an input of the instance (not one a
connection feeds). Before each of the instance's steps, at its start t, each input takes the table's value there the
way FMPy's co-simulation applies it (`Input.interpolate` with after_event, the one implementation, FMPy's): a
continuous one (Float32, Float64 of continuous variability) interpolated linearly, a discrete one held from the last
row at or before t, at a jump (two rows of one time) the value after it; before the first row the first value, after
the last the last. At t = 0 the values are set in Initialization Mode with the parameters. Unlike FMPy, which adds a
communication point at an input event between two output times (a variable-step FMU), the steps stay on the tick:
an event between two ticks takes effect at the next.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .errors import DescriptionError
from .fmi.model_description import checked_value, fmi_type
from .user_files import MAX_BYTES, UserFileError, read_text, regular_file

MAX_ROWS = 1_000_000  # a table's rows: 24 MB of doubles a column


class InputTable:
    """One instance's input file, read and checked against its model description; values(t) at a step's start."""

    def __init__(self, instance: str, path: Path, md, fed: set[str]) -> None:
        """fed: the instance's inputs a connection sets (a table may not set them too)."""
        self.instance, self.path = instance, Path(path)
        names, columns = _read(self.path, instance)
        if not names or names[0].lower() != "time":
            raise DescriptionError(f"{instance}: input file {path}: its first column must be the time, named time")
        self.t = columns[0]
        if not (np.all(np.isfinite(self.t)) and np.all(np.diff(self.t) >= 0)):
            raise DescriptionError(f"{instance}: input file {path}: the times must be finite and non-decreasing")
        variables = {v.name: v for v in md.modelVariables}
        self.columns = []  # (variable, its values, discrete)
        for name, values in zip(names[1:], columns[1:]):
            v = variables.get(name)
            if v is None or v.causality != "input":
                raise DescriptionError(f"{instance}: input file {path}: column {name!r} is not an input of the FMU")
            if name in fed:
                raise DescriptionError(f"{instance}: input file {path}: {name} is fed by a connection too")
            continuous = fmi_type(v) in ("Float32", "Float64") and v.variability == "continuous"
            self.columns.append((v, values, not continuous))
        for v, values, _ in self.columns:  # every value of the table fits its variable: refused before the run
            for x in np.unique(values):
                checked_value(instance, v, v.name, _python(x, v))

    def values(self, t: float) -> dict[str, object]:
        """{input: its value at t}, FMPy's interpolation."""
        from fmpy.simulation import Input

        out = {}
        for v, values, discrete in self.columns:
            value, _ = Input.interpolate(time=t, t=self.t, table=values[np.newaxis, :], discrete=discrete,
                                         after_event=True)
            out[v.name] = _python(np.asarray(value).reshape(-1)[0], v)
        return out


def _python(x, v):
    """A table's number as the Python value its variable takes (a whole number for the integer types and Booleans)."""
    name = fmi_type(v)
    if name == "Boolean":
        return bool(x)
    if name in ("Float32", "Float64"):
        return float(x)
    return int(x) if float(x).is_integer() else float(x)  # checked_value refuses a fraction for an integer type


def _read(path: Path, instance: str) -> tuple[list[str], list[np.ndarray]]:
    """(column names, columns as float64 arrays) of a CSV or Parquet file, bounded in size."""
    try:
        regular_file(path, "input file")
        if path.suffix.lower() in (".parquet", ".pq"):
            if path.stat().st_size > MAX_BYTES:
                raise UserFileError(f"{path}: more than the {MAX_BYTES} bytes a file given to tiltload may have")
            import pyarrow.parquet as pq

            table = pq.read_table(path)
            if table.num_rows > MAX_ROWS:
                raise UserFileError(f"{path}: {table.num_rows} rows, more than {MAX_ROWS}")
            names = list(table.column_names)
            columns = [np.asarray(table.column(n).to_numpy(zero_copy_only=False), dtype=np.float64) for n in names]
            return names, columns
        lines = [line for line in read_text(path).splitlines() if line.strip()]
    except UserFileError as err:
        raise DescriptionError(f"{instance}: {err}") from None
    except (OSError, ValueError, TypeError) as err:  # pyarrow's errors on a file that is no Parquet, a column no number
        raise DescriptionError(f"{instance}: input file {path}: {err}") from None
    if len(lines) > MAX_ROWS + 1:
        raise DescriptionError(f"{instance}: input file {path}: more than {MAX_ROWS} rows")
    names = [n.strip().strip('"') for n in lines[0].split(",")] if lines else []
    rows = []
    for k, line in enumerate(lines[1:], start=2):
        cells = line.split(",")
        if len(cells) != len(names):
            raise DescriptionError(f"{instance}: input file {path}, line {k}: {len(cells)} values for {len(names)} columns")
        try:
            rows.append([1.0 if c.strip().lower() == "true" else 0.0 if c.strip().lower() == "false" else float(c)
                         for c in cells])
        except ValueError:
            raise DescriptionError(f"{instance}: input file {path}, line {k}: a value that is no number") from None
    if not rows:
        raise DescriptionError(f"{instance}: input file {path}: no rows")
    data = np.array(rows, dtype=np.float64)
    return names, [data[:, j] for j in range(len(names))]

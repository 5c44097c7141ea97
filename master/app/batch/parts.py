"""The parts a campaign or a falsification stored in <out>/parts, read back to go on where it stopped: each part read
here, and one that is not a part this command wrote (garbage, empty, another tool's Parquet, columns missing or of
another type) named in one line and refused before any cluster starts, never read as a run's outcome.
"""

from __future__ import annotations

import os
from pathlib import Path

from ..user_error import UserError


def part_paths(folder: Path) -> list[Path]:
    """The .parquet files of <out>/parts (none if it is not there yet); anything else where that folder goes (a file, a
    FIFO) refused in one line, before any cluster starts: the command would fail making it after the runs began."""
    if os.path.lexists(folder) and not folder.is_dir():  # a dangling link too: making the folder would fail
        raise UserError(f"{folder} is not a folder: the command stores its runs there; move it away or choose another --out")
    return sorted(folder.glob("*.parquet")) if folder.is_dir() else []


def read_part(path: Path, columns: dict[str, type | tuple[type, ...]]) -> list[dict]:
    """The rows of one stored part, each holding the columns with values of their types (a bool is no int unless bool is named)."""
    import pyarrow.parquet as pq

    hint = f"move it out of {path.parent} and rerun (its runs run again)"
    try:
        rows = pq.read_table(path).to_pylist()
    except Exception as err:  # pyarrow's many error types for a file that is not Parquet
        first = (str(err).strip().splitlines() or [type(err).__name__])[0][:120]
        raise UserError(f"stored part {path} is not a Parquet file ({first}): {hint}") from None
    if not rows:
        raise UserError(f"stored part {path} holds no rows: {hint}")
    for name, kind in columns.items():
        if name not in rows[0]:
            raise UserError(f"stored part {path} has no column {name} (not a part this command wrote): {hint}")
        bad = next((r for r in rows if not _is(r.get(name), kind)), None)
        if bad is not None:
            raise UserError(f"stored part {path}: its column {name} holds {str(bad.get(name))[:40]!r}, not what this "
                            f"command stores there: {hint}")
    return rows


def _is(value, kind: type | tuple[type, ...]) -> bool:
    kinds = kind if isinstance(kind, tuple) else (kind,)
    return isinstance(value, kinds) and (bool in kinds or not isinstance(value, bool))

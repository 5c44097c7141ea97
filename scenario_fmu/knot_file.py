"""A mission's knot file: the table the scenario FMU reads from its waypoints_file parameter (scenario_waypoints.c),
written (`knot_text`) and read back as the FMU reads it (`read_knots`, bounded and checked; a file read once while it
is unchanged), and the reference a scenario's parameters name (`from_parameters`). The reference itself: waypoints.py."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import numpy as np

from .files import ScenarioFileError
from .waypoints import KNOT_COLUMNS, KNOT_LINE, MAX_WAYPOINTS, MinimumJerk

_KNOT_LINE_FORMAT = ",".join(["%.17g"] * len(KNOT_COLUMNS)) + "\n"  # one format a line (f"{x:.17g}", the same text)


def knot_text(knots: np.ndarray) -> str:
    """The knot file's text (what the scenario FMU reads from waypoints_file)."""
    return ",".join(KNOT_COLUMNS) + "\n" + "".join(_KNOT_LINE_FORMAT % tuple(row) for row in np.asarray(knots).tolist())


_READ: dict[str, tuple[tuple, MinimumJerk]] = {}  # a knot file's path -> (its size, mtime, inode, device), its reference
_MOST_READ = 8  # files remembered (a search's feasibility check reads each moved mission's twice)


def read_knots(path: str | Path) -> MinimumJerk:
    """The reference a knot file describes, read as the scenario FMU reads it: a regular file of at most MAX_WAYPOINTS
    knots (its size checked before it is read), the header, 13 finite numbers a line, times increasing. Read again
    only when the file changed (its size, modification time, inode or device); the reference's arrays are read-only."""
    path = os.fspath(path)  # (a string: a search reads a moved mission's file at every point)
    try:
        info = os.stat(path)
    except OSError as err:
        raise ScenarioFileError(f"waypoints_file {path}: {err.strerror or err}") from None
    if not stat.S_ISREG(info.st_mode):
        raise ScenarioFileError(f"waypoints_file {path}: not a regular file")
    if info.st_size > (MAX_WAYPOINTS + 1) * (KNOT_LINE + 2):
        raise ScenarioFileError(f"waypoints_file {path}: {info.st_size} bytes, more than {MAX_WAYPOINTS} knots take")
    seen = (info.st_size, info.st_mtime_ns, info.st_ino, info.st_dev)
    known = _READ.get(path)
    if known is not None and known[0] == seen:
        return known[1]
    with open(path, "rb", opener=lambda p, flags: os.open(p, flags | getattr(os, "O_NONBLOCK", 0))) as f:
        lines = f.read().decode("ascii", errors="replace").splitlines()
    if not lines or lines[0] != ",".join(KNOT_COLUMNS):
        raise ScenarioFileError(f"waypoints_file {path}: line 1 must be the header {','.join(KNOT_COLUMNS)}")
    knots = np.empty((len(lines) - 1, len(KNOT_COLUMNS)))
    for i, line in enumerate(lines[1:]):
        try:
            knots[i] = [float(x) for x in line.split(",")]
        except ValueError:
            raise ScenarioFileError(f"waypoints_file {path}: line {i + 2}: not {len(KNOT_COLUMNS)} numbers") from None
    return _remember(path, seen, knots)


def known_knots(path: str | Path, info, knots: np.ndarray) -> None:
    """The knot file at path that held knot_text(knots) when its stat was info, read without parsing its text again:
    the %.17g numbers read back as these exact doubles, so its reference is read_knots' own (a moved mission's file is
    written by the search and read by its feasibility check at once). A file changed since (its stat) is read again;
    a table read_knots would refuse is not remembered (its readers meet the file's problem as before)."""
    seen = (info.st_size, info.st_mtime_ns, info.st_ino, info.st_dev)
    path = os.fspath(path)
    known = _READ.get(path)
    if known is None or known[0] != seen:  # (a mission run again finds its file, and its reference, as they were)
        try:
            _remember(path, seen, np.array(knots, dtype=float))
        except ScenarioFileError:
            pass


def _remember(path: str, seen: tuple, knots: np.ndarray) -> MinimumJerk:
    """The reference of a knot table read from path (as it was: seen), checked as the scenario FMU checks it, kept
    in _READ (read-only)."""
    if knots.ndim != 2 or knots.shape[1] != len(KNOT_COLUMNS):
        raise ScenarioFileError(f"waypoints_file {path}: not {len(KNOT_COLUMNS)} numbers a line")
    if not 2 <= knots.shape[0] <= MAX_WAYPOINTS:
        raise ScenarioFileError(f"waypoints_file {path}: {knots.shape[0]} knots; a mission has 2 to {MAX_WAYPOINTS}")
    if not np.all(np.isfinite(knots)) or not np.all(np.diff(knots[:, 0]) > 0):
        raise ScenarioFileError(f"waypoints_file {path}: a value that is not finite, or times that do not increase")
    ref = MinimumJerk.from_knots(knots)
    for array in (ref.t, ref.p, ref.v, ref.a):
        array.flags.writeable = False  # shared by every later read of the file
    _READ.pop(path, None)
    if len(_READ) >= _MOST_READ:
        _READ.pop(next(iter(_READ)))
    _READ[path] = (seen, ref)
    return ref



def from_parameters(values: dict) -> MinimumJerk:
    """The reference the scenario FMU's waypoints_file parameter names (relative paths are not resolved: the FMU's
    resources folder is the FMU's)."""
    name = str(values.get("waypoints_file", ""))
    if not name:
        raise ScenarioFileError("trajectory 4 needs waypoints_file: the knot file of the mission")
    return read_knots(name)

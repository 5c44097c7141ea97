"""Which reference a run flies: a thesis trajectory (0-3), a built-in shape, or a file; as scenario FMU parameters.

    1                          the thesis's trajectory 1 (0 hover, 2 Table 5.3, 3 Appendix A's circle)
    lemniscate                 a built-in shape with its defaults (also figure-eight, lissajous,
    step-z:size=0.5,onset=2    step-x/-y/-z, ramp-x/-y/-z), or with NAME:KEY=VALUE,... overrides
    mission.csv                time-stamped waypoints (t,x,y,z[,psi][,vx,...,apsi]), a minimum-jerk reference
    mission.yaml / .json       waypoints: [{t, x, y, z, ...}, ...], or a shape: {shape: lissajous, size: [2, 2, 0.5], ...}

A shape's keys are the scenario FMU's shape_* parameters without the prefix (size_x, period, onset, ...), and
size for a step or ramp along its axis; in a file, center, size, ratio and phase may be [x, y, z] lists.
"""

from __future__ import annotations

import math
import os
import stat
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from . import knot_file, shapes, trajectories, twin, waypoints
from .files import Reader, ScenarioFileError, read_rows, read_structured

THESIS = (0, 1, 2, 3)
VECTORS = ("center", "size", "ratio", "phase")
# the built-ins and their own defaults (beyond shapes.SHAPE_PARAMETERS')
BUILT_IN = {
    "lemniscate": ("lemniscate", {}),
    "figure-eight": ("lemniscate", {}),
    "lissajous": ("lissajous", {"size_x": 2.0, "size_y": 2.0, "size_z": 0.5, "period": 40.0}),
    **{f"step-{a}": ("step", {"size_x": 0.0, "size_y": 0.0, "size_z": 0.0, f"size_{a}": 1.0, "duration": 20.0}) for a in "xyz"},
    **{f"ramp-{a}": ("ramp", {"size_x": 0.0, "size_y": 0.0, "size_z": 0.0, f"size_{a}": 2.0, "period": 10.0, "duration": 25.0})
       for a in "xyz"},
}
SHAPE_SCHEMA = {
    "type": "object", "additionalProperties": False, "required": ["shape"],
    "properties": {
        "shape": {"enum": ["lemniscate", "figure-eight", "lissajous", "step", "ramp"]},
        **{k: {"type": "array", "items": {"type": "number"}, "minItems": 3, "maxItems": 3} for k in VECTORS},
        **{n: {"type": "number"} for n in shapes.SHAPE_NAMES},
    },
}


@dataclass(frozen=True)
class Trajectory:
    """A reference for the scenario FMU: its trajectory code and other parameters, the load's start, the duration."""

    label: str  # in file names and messages: "1", "lemniscate", the file's stem
    code: int
    settings: tuple[tuple[str, float | int], ...]  # scenario FMU parameters besides `trajectory`
    start: tuple[float, float, float]
    duration: float
    source: str = ""  # the file it came from, if any
    knots: tuple[tuple[float, ...], ...] = ()  # a waypoint mission's knot table (waypoints.KNOT_COLUMNS), written for the FMU

    def fmu_parameters(self, folder: Path) -> dict[str, float | int | str]:
        """The scenario FMU's parameters; a mission's knot file written into folder first (named by its content, so
        the same mission is one file however often it runs), and named by waypoints_file."""
        if not self.knots:
            return self.parameters
        import hashlib

        knots = np.array(self.knots)
        text = knot_file.knot_text(knots)
        data = text.encode()
        where = str(_resolved(str(folder), "" if os.path.isabs(folder) else os.getcwd()))
        path = os.path.join(where, f"mission-{hashlib.sha256(data).hexdigest()[:20]}.csv")  # (str: a search writes one
        try:  # a point, and pathlib's objects cost more than the writing)
            info = os.stat(path)  # before it is read: a file changed after is read again
            same = stat.S_ISREG(info.st_mode) and _read(path, len(data) + 1) == data  # (never opens a pipe)
        except OSError:
            same = False
        if not same:
            partial = f"{path}.{os.getpid()}.partial"
            try:
                info = _write(partial, data)
            except FileNotFoundError:  # the folder's first file
                os.makedirs(where, exist_ok=True)
                info = _write(partial, data)
            os.replace(partial, path)  # whole or not at all, for a reader in another process
        knot_file.known_knots(path, info, knots)  # the feasibility check reads it next: not parsed again
        if len(path) > waypoints.PATH_LENGTH:
            raise ScenarioFileError(f"the knot file's path {path[:60]}... is longer than {waypoints.PATH_LENGTH} characters")
        return {**self.parameters, "waypoints_file": path}

    @property
    def parameters(self) -> dict[str, float | int]:
        return {"trajectory": self.code, **dict(self.settings)}

    @classmethod
    def from_dict(cls, d: dict) -> Trajectory:
        """From its dataclasses.asdict form (as a snapshot keeps it: JSON lists for the tuples)."""
        return cls(d["label"], d["code"], tuple(tuple(x) for x in d["settings"]), tuple(d["start"]), d["duration"],
                   d.get("source", ""), tuple(tuple(float(v) for v in k) for k in d.get("knots", ())))

    def __str__(self) -> str:
        return self.label


def _read(path: str, most: int) -> bytes:
    with open(path, "rb") as f:
        return f.read(most)


def _write(path: str, data: bytes):
    """data into a new file at path (replaced if there), and the file's stat (a rename keeps it)."""
    with open(path, "wb") as f:
        f.write(data)
        return os.fstat(f.fileno())


@lru_cache(maxsize=8)
def _resolved(folder: str, cwd: str) -> Path:
    """The folder's absolute path from cwd, worked out once (a search writes a mission's file at every point: 0.04 ms a
    time)."""
    return (Path(cwd) / folder).resolve()


def thesis(code: int) -> Trajectory:
    """Trajectory 0-3: the FMU's own tables (the load starts 30 cm off trajectories 1 and 2, Sec. 5.1.2)."""
    return Trajectory(str(code), code, (), trajectories.START.get(code, (0.0, 0.0, 0.0)), trajectories.DURATION.get(code, 20.0))


def _from_parameters(label: str, code: int, settings: dict, source: str = "") -> Trajectory:
    values = {"trajectory": code, **settings}
    start = twin.evaluate(values, [0.0]).p[0]
    return Trajectory(label, code, tuple(settings.items()), tuple(float(x) for x in start), twin.duration(values), source)


def _shape(label: str, name: str, given: dict, where: str) -> Trajectory:
    kind, defaults = BUILT_IN.get(name, (name, {}))
    values = {p.name: p.default for p in shapes.SHAPE_PARAMETERS} | defaults
    for key, value in given.items():
        if key == "size" and name in BUILT_IN and kind in ("step", "ramp"):
            key = f"size_{name[-1]}"
        if key not in values:
            raise ScenarioFileError(f"{where}: {kind} has no parameter {key!r} (it has {', '.join(shapes.SHAPE_NAMES)}"
                                    + (", size" if name in BUILT_IN and kind in ("step", "ramp") else "") + ")")
        if not (isinstance(value, (int, float)) and math.isfinite(value)):
            raise ScenarioFileError(f"{where}: {key} = {value} is not a finite number")
        values[key] = float(value)
    for key, value in values.items():
        if abs(value) > 1e5:
            raise ScenarioFileError(f"{where}: {key} = {value:.6g} is beyond the +-1e5 a shape's parameters may take")
    for key in ("period", "duration"):
        if not values[key] > 0:
            raise ScenarioFileError(f"{where}: {key} must be positive, got {values[key]:g}")
    for key in ("duration", "onset", "rise"):
        if values[key] > waypoints.MAX_TIME:
            raise ScenarioFileError(f"{where}: {key} = {values[key]:g} s is beyond {waypoints.MAX_TIME:g} s (a run's length is bounded: "
                                    "docs/test_bench.md)")
    for key in ("rise", "onset"):
        if not values[key] >= 0:
            raise ScenarioFileError(f"{where}: {key} must be >= 0, got {values[key]:g}")
    code = {v: k for k, v in shapes.SHAPES.items()}[kind]
    return _from_parameters(label, code, {f"shape_{k}": v for k, v in values.items()})


def _overrides(text: str, where: str) -> dict:
    out = {}
    for item in filter(None, text.split(",")):
        key, sep, value = item.partition("=")
        try:
            out[key.strip()] = float(value)
        except ValueError:
            raise ScenarioFileError(f"{where}: {item!r} must be KEY=NUMBER") from None
        if not sep:
            raise ScenarioFileError(f"{where}: {item!r} must be KEY=NUMBER")
    return out


def _waypoint_file(path: Path, rows: list, where: list[str]) -> Trajectory:
    waypoints.check(rows, where, str(path))
    ref = waypoints.minimum_jerk(rows)
    return Trajectory(path.stem, twin.WAYPOINTS, (), ref.start, ref.duration, str(path),
                      tuple(tuple(float(v) for v in k) for k in ref.knots()))


def read_file(path: Path, read: Reader) -> Trajectory:
    """A trajectory file: CSV waypoints, or a JSON/YAML document of waypoints or of a shape."""
    if path.suffix.lower() == ".csv":
        return _waypoint_file(path, *read_rows(path, waypoints.FIELDS, waypoints.REQUIRED, read))
    data = read_structured(path, read)
    if isinstance(data, dict) and "shape" in data:
        import jsonschema

        errors = sorted(jsonschema.Draft202012Validator(SHAPE_SCHEMA).iter_errors(data), key=lambda e: list(e.path))
        if errors:
            at = ".".join(str(p) for p in errors[0].absolute_path) or "(top level)"
            raise ScenarioFileError(f"{path}: {at}: {errors[0].message}")
        given = {k: v for k, v in data.items() if k != "shape" and k not in VECTORS}
        for k in VECTORS:
            given.update({f"{k}_{a}": v for a, v in zip("xyz", data.get(k, ()))})
        return _shape(path.stem, data["shape"], given, str(path))
    if not (isinstance(data, dict) and set(data) == {"waypoints"} and isinstance(data["waypoints"], list)):
        raise ScenarioFileError(f"{path}: a trajectory file is a mapping with `waypoints: [...]` (or `shape: ...`)")
    rows = data["waypoints"]
    where = [f"waypoints.{i}" for i in range(len(rows))]
    for row, at in zip(rows, where):
        if not isinstance(row, dict):
            raise ScenarioFileError(f"{path}: {at}: a waypoint is a mapping of t, x, y, z[, psi, vx, ...], got {row!r}")
    return _waypoint_file(path, rows, where)


def resolve(text: str, base: Path | None = None, read: Reader | None = None) -> Trajectory:
    """A trajectory from its command-line or spec text (module docstring); relative files are under base, read by
    `read` (master.app.inputs.READER: a text naming a file without one is an error)."""
    text = str(text).strip()
    if text.isdigit():
        code = int(text)
        if code not in THESIS:
            raise ScenarioFileError(f"trajectory {code}: the thesis's are 0 (hover), 1, 2 and 3")
        return thesis(code)
    name, _, rest = text.partition(":")
    if name in BUILT_IN:
        given = _overrides(rest, f"trajectory {text}")
        label = "_".join([name, *(f"{k}{v:g}" for k, v in given.items())])  # a file name's stem
        return _shape(label, name, given, f"trajectory {text}")
    path = Path(text) if base is None or Path(text).is_absolute() else Path(base) / text
    if not path.is_file() and path.suffix.lower() not in (".csv", ".json", ".yaml", ".yml"):
        raise ScenarioFileError(f"trajectory {text!r}: neither 0-3, a built-in ({', '.join(BUILT_IN)}) nor a trajectory file")
    if read is None:
        raise ScenarioFileError(f"trajectory {text!r}: a trajectory file is read through the master's input layer (no reader given)")
    return read_file(path, read)


def as_trajectory(value, base: Path | None = None, read: Reader | None = None) -> Trajectory:
    """A Trajectory, an int (thesis) or a text (resolve)."""
    if isinstance(value, Trajectory):
        return value
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
        return resolve(str(int(value)))
    return resolve(str(value), base, read)

"""Snapshots of a running execution, and runs that continue from one as if never interrupted.

A snapshot holds every FMU's own serialized state (fmi2SerializeFMUstate) and the master's: the tick,
every instance's outputs as the engine holds them (after faults), the delay lines, the faults' state
and each observer's (metric integrals, the log's position in its cadence). A continued run loads the
same FMUs, initializes them, restores all of that and goes on from the next tick: its numbers and
its log are those of the uninterrupted run from there on, bit for bit.

On disk: one zip archive, manifest.json (the master's state as JSON: floats round-trip exactly) and
fmu/<instance>.state (the FMUs' bytes). The zip's CRCs catch a truncated or damaged file. A snapshot
carries a fingerprint of its system (instances, the FMUs' GUIDs and SHA-256 digests, a digest of each
instance's parameters, periods, timing, connections): a snapshot of another system, another build or
another scenario is refused, naming what differs.

A snapshot is data. No pickle; the manifest is checked against SCHEMA before any of it is used; members
are read only up to bounds checked first (a zip bomb is refused by its declared size and never read
whole); and it never says where an FMU is: the caller locates the FMUs (the command line's folder) and
check() compares each file's digest with the one recorded before anything is loaded.
"""

from __future__ import annotations

import hashlib
import json
import zipfile
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import DescriptionError
from .fmi.model_description import checked_value

FORMAT = "tiltload-snapshot/2"
# bounds checked before a member is read (declared sizes) and while it is (actual bytes): a state of the loop's FMUs
# is a few kB, a manifest tens of kB; these leave room for large third-party FMUs and refuse a zip bomb
MAX_MANIFEST = 64 << 20
MAX_STATE = 256 << 20
MAX_STATES_TOTAL = 1 << 30
MAX_MEMBERS = 4096
_DTYPE = {"Real": np.float64, "Integer": np.int32, "Boolean": np.int32}


class SnapshotError(DescriptionError):
    """A snapshot that cannot be written, read or continued from; the message names the file and the problem."""


@dataclass
class Snapshot:
    tick: float
    ticks_done: int
    fingerprint: dict
    states: dict[str, bytes]  # instance -> the FMU's serialized state
    values: dict[str, dict[str, list]]  # instance -> type -> the outputs as the engine held them
    delay_lines: dict[str, dict[str, list]]  # instance -> type -> slots x outputs (empty without delays)
    faults: list  # the fault schedule (described) whose state `manipulator` is
    manipulator: dict | None
    observers: dict[str, dict]  # observer class name -> its state
    application: dict = field(default_factory=dict)  # what the caller wants back (e.g. the run's options)
    settings: dict = field(default_factory=dict)  # {instance: {name: value}} to set after restoring (a branch's own)

    @property
    def time(self) -> float:
        return self.ticks_done * self.tick


_DIGESTS: dict[tuple, str] = {}  # per process: (path, inode, size, mtime) -> digest; a replaced file is hashed again


def file_digest(path: Path) -> str:
    """SHA-256 of a file (an FMU), read in blocks; once per version of the file (its inode, size and modification time:
    a run branched from a snapshot again and again checks the same FMUs each time, fmus' hashing dominated its cost)."""
    try:
        st = Path(path).stat()
    except OSError as err:
        raise SnapshotError(f"cannot read {path}: {err.strerror or err}") from None
    key = (str(path), st.st_ino, st.st_size, st.st_mtime_ns)
    if key not in _DIGESTS:
        _DIGESTS[key] = _hash_file(path)
    return _DIGESTS[key]


def _hash_file(path: Path) -> str:
    h = hashlib.sha256()
    try:
        with open(path, "rb") as f:
            for block in iter(lambda: f.read(1 << 20), b""):
                h.update(block)
    except OSError as err:
        raise SnapshotError(f"cannot read {path}: {err.strerror or err}") from None
    return h.hexdigest()


def parameters_digest(parameters: dict) -> str:
    """SHA-256 of an instance's parameters as the system sets them (the scenario, trajectory, seed, wind, --set)."""
    return hashlib.sha256(json.dumps(parameters, sort_keys=True, default=str).encode()).hexdigest()


def fingerprint(execution) -> dict:
    """What must be the same for a snapshot to continue in this execution."""
    system = execution.system
    return {"tick": system.tick,
            "instances": [{"name": i.name, "guid": execution.model_descriptions[i.name].guid, "every": execution.every[i.name],
                           "timing": i.timing, "sha256": file_digest(i.fmu), "parameters": parameters_digest(i.parameters)}
                          for i in system.instances],
            "links": sorted([lk.source, lk.source_vr, lk.target, lk.target_vr, lk.type, lk.delay] for lk in execution.links)}


def take(execution, application: dict | None = None) -> Snapshot:
    """The execution's state between two ticks. Every FMU must be able to serialize its state."""
    from .faults.schedule import describe

    _from_zero(execution)
    for name, slave in execution.instances.items():
        if not slave.can_serialize:
            raise SnapshotError(f"{name}: its FMU cannot serialize its state (canSerializeFMUstate is false): "
                                "no snapshot of this system")
    loop = execution.loop
    loop.sync_faults()  # the faults the C loop applies keep their state there
    observers = {}
    for obs in execution.observers:
        state = obs.snapshot_state()
        if state is not None:
            observers.setdefault(type(obs).__name__, state)
    return Snapshot(
        execution.system.tick, execution.ticks_done, fingerprint(execution),
        {name: slave.get_state() for name, slave in execution.instances.items()},
        {name: {t: v.tolist() for t, v in slave.values.items()} for name, slave in execution.instances.items()},
        {name: {t: a.tolist() for t, a in lines.items()} for name, lines in zip(loop.names, loop.delay_line())},
        [describe(f) for f in execution.system.faults],
        execution.manipulator.snapshot_state() if execution.manipulator is not None else None,
        observers, dict(application or {}))


def _from_zero(execution) -> None:
    """A snapshot holds a run from t = 0 (its tick count is its time): one that started elsewhere is refused."""
    if execution.system.start_time:
        raise SnapshotError(f"the system starts at {execution.system.start_time:g} s: snapshots are of runs from t = 0 only")


def check(execution, snap: Snapshot) -> None:
    """Before anything is loaded: the snapshot is of this system and build, and its settings are tunable parameters."""
    _from_zero(execution)
    check_compatible(snap.fingerprint, fingerprint(execution))
    for name, md in execution.model_descriptions.items():  # the shapes of what restore() writes, before anything loads
        if name not in snap.states or name not in snap.values:
            raise SnapshotError(f"{name}: the snapshot holds no state of it")
        outputs = {t: sum(1 for v in md.modelVariables if v.causality == "output" and v.type == t) for t in _DTYPE}
        for t, values in snap.values[name].items():
            if np.shape(values) != (outputs[t],):
                raise SnapshotError(f"{name}: the snapshot holds {np.shape(values)[0] if np.ndim(values) == 1 else 'no list of'} "
                                    f"{t} outputs, its FMU has {outputs[t]}")
    for name, values in snap.settings.items():
        if name not in execution.model_descriptions:
            raise SnapshotError(f"--set {name}.…: the system has no instance '{name}'")
        variables = {v.name: v for v in execution.model_descriptions[name].modelVariables}
        for key in values:
            v = variables.get(key)
            if v is None:
                raise SnapshotError(f"{name} has no variable '{key}' to set")
            if v.causality == "parameter" and v.variability != "tunable":
                raise SnapshotError(f"{name}.{key} is a {v.variability} parameter: only tunable parameters can change in a "
                                    "run continued from a snapshot")
            values[key] = checked_value(name, v, key, values[key])  # a number that fits it, finite, in its range


def restore(execution, snap: Snapshot) -> None:
    """Put an initialized execution (same system) where the snapshot was; called before the observers start."""
    check(execution, snap)
    for name, slave in execution.instances.items():
        if name not in snap.states or name not in snap.values:
            raise SnapshotError(f"{name}: the snapshot holds no state of it")
        for t, values in snap.values[name].items():  # shapes first: a mismatch is the snapshot's, said in one line
            if t not in slave.values or np.shape(values) != slave.values[t].shape:
                raise SnapshotError(f"{name}: the snapshot's {t} outputs do not match its FMU's")
        slave.set_state(snap.states[name])
        for t, values in snap.values[name].items():
            slave.values[t][:] = np.asarray(values, dtype=_DTYPE[t])
    for name, values in snap.settings.items():  # a branch's own values of tunable parameters (checked already)
        execution.instances[name].set_values(values)
    execution.ticks_done, execution.time = snap.ticks_done, snap.time


def restore_loop(execution, snap: Snapshot) -> None:
    """The parts that live in the tick loop's plan and in the faults: after the plan is built."""
    from .faults.schedule import describe

    loop = execution.loop
    for name, lines in zip(loop.names, loop.delay_line()):
        for t, array in lines.items():
            saved = snap.delay_lines.get(name, {}).get(t)
            if saved is None or np.shape(saved) != array.shape:
                raise SnapshotError(f"{name}: the snapshot's {t} delay line does not match this system's")
            array[:] = np.asarray(saved, dtype=array.dtype)
    loop.plan.ticks_done = snap.ticks_done
    same_faults = [describe(f) for f in execution.system.faults] == snap.faults
    if execution.manipulator is not None and same_faults and snap.manipulator is not None:
        execution.manipulator.restore_state(snap.manipulator)
        loop.push_faults()


def restore_observers(execution, snap: Snapshot) -> None:
    for obs in execution.observers:
        state = snap.observers.get(type(obs).__name__)
        if state is not None:
            obs.restore_state(state)


def check_compatible(theirs: dict, mine: dict) -> None:
    if theirs["tick"] != mine["tick"]:
        raise SnapshotError(f"the snapshot's tick is {theirs['tick']} s, this system's {mine['tick']} s")
    a = {i["name"]: i for i in theirs["instances"]}
    b = {i["name"]: i for i in mine["instances"]}
    if list(a) != list(b):
        raise SnapshotError(f"the snapshot is of another system (instances {', '.join(a)}; here {', '.join(b)})")
    for name in a:
        if a[name]["guid"] != b[name]["guid"]:
            raise SnapshotError(f"{name}: the snapshot was taken with another build of its FMU (GUID {a[name]['guid']}, "
                                f"here {b[name]['guid']})")
        for key in ("every", "timing"):
            if a[name][key] != b[name][key]:
                raise SnapshotError(f"{name}: its {key} differs from the snapshot's ({a[name][key]} there, {b[name][key]} here)")
        if a[name]["sha256"] != b[name]["sha256"]:
            raise SnapshotError(f"{name}: its FMU is not the file the snapshot was taken with (SHA-256 {a[name]['sha256'][:12]}… "
                                f"there, {b[name]['sha256'][:12]}… here): nothing was loaded")
        if a[name]["parameters"] != b[name]["parameters"]:
            raise SnapshotError(f"{name}: its parameters differ from those the snapshot was taken with (another scenario, "
                                "trajectory, seed, wind or --set: the snapshot's options were edited, or are of another run)")
    if theirs["links"] != mine["links"]:
        raise SnapshotError("the snapshot's system is connected differently")


# ----------------------------------------------------------------------------------------------------- files

def write(snap: Snapshot, path: Path) -> Path:
    path = Path(path)
    manifest = {"format": FORMAT, "tick": snap.tick, "ticks_done": snap.ticks_done, "fingerprint": snap.fingerprint,
                "values": snap.values, "delay_lines": snap.delay_lines, "faults": snap.faults, "manipulator": snap.manipulator,
                "observers": snap.observers, "application": snap.application, "states": sorted(snap.states)}
    partial = path.with_name(path.name + ".partial")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as z:
            z.writestr("manifest.json", json.dumps(manifest))
            for name, state in snap.states.items():
                z.writestr(f"fmu/{name}.state", state)
        partial.replace(path)
    except OSError as err:
        partial.unlink(missing_ok=True)
        raise SnapshotError(f"cannot write the snapshot {path}: {err.strerror or err}") from None
    return path


_NAME = r"^[A-Za-z_][A-Za-z0-9_]*$"  # an instance's name (system.SCHEMA's): also the file name of its state
_NUMBERS = {"type": "array", "items": {"type": ["number", "boolean"]}}
_BY_TYPE = {"type": "object", "propertyNames": {"enum": list(_DTYPE)}, "additionalProperties": {"type": "array"}}
SCHEMA = {
    "type": "object",
    "required": ["format", "tick", "ticks_done", "fingerprint", "values", "delay_lines", "faults", "manipulator", "observers",
                 "application", "states"],
    "additionalProperties": False,
    "properties": {
        "format": {"const": FORMAT},
        "tick": {"type": "number", "exclusiveMinimum": 0},
        "ticks_done": {"type": "integer", "minimum": 0, "maximum": 2**53},
        "fingerprint": {
            "type": "object", "required": ["tick", "instances", "links"], "additionalProperties": False,
            "properties": {
                "tick": {"type": "number", "exclusiveMinimum": 0},
                "instances": {"type": "array", "minItems": 1, "maxItems": MAX_MEMBERS, "items": {
                    "type": "object", "required": ["name", "guid", "every", "timing", "sha256", "parameters"],
                    "additionalProperties": False,
                    "properties": {"name": {"type": "string", "pattern": _NAME}, "guid": {"type": ["string", "null"]},
                                   "every": {"type": "integer", "minimum": 1}, "timing": {"type": ["string", "null"]},
                                   "sha256": {"type": "string", "pattern": "^[0-9a-f]{64}$"},
                                   "parameters": {"type": "string", "pattern": "^[0-9a-f]{64}$"}}}},
                "links": {"type": "array", "items": {"type": "array"}}}},
        "values": {"type": "object", "propertyNames": {"pattern": _NAME},
                   "additionalProperties": {**_BY_TYPE, "additionalProperties": _NUMBERS}},
        "delay_lines": {"type": "object", "propertyNames": {"pattern": _NAME}, "additionalProperties": _BY_TYPE},
        "faults": {"type": "array"},
        "manipulator": {"type": ["object", "null"]},
        "observers": {"type": "object", "additionalProperties": {"type": "object"}},
        "application": {"type": "object"},
        "states": {"type": "array", "maxItems": MAX_MEMBERS, "uniqueItems": True, "items": {"type": "string", "pattern": _NAME}},
    },
}


def check_manifest(manifest, where) -> None:
    """The manifest's shape (SCHEMA): the first problem, named by its path, in one line."""
    from .user_files import schema_problem

    if isinstance(manifest, dict) and manifest.get("format") != FORMAT:
        found = manifest.get("format")
        older = isinstance(found, str) and found.startswith("tiltload-snapshot/")
        raise SnapshotError(f"{where} is not a tiltload snapshot (format {found!r}, expected {FORMAT})"
                            + ("; it was taken by another version of tiltload: take it again" if older else ""))
    problem = schema_problem(manifest, SCHEMA, limit=160)
    if problem:
        raise SnapshotError(f"{where}: its manifest is not a snapshot's: {problem}")


def _read_member(z: zipfile.ZipFile, name: str, limit: int, where) -> bytes:
    """A member of the archive, refused by its declared size and never read past limit (a zip bomb stays unread)."""
    try:
        info = z.getinfo(name)
    except KeyError:
        raise SnapshotError(f"{where} is not a complete snapshot (no {name})") from None
    if info.file_size > limit:
        raise SnapshotError(f"{where}: {name} declares {info.file_size} bytes, more than a snapshot holds ({limit}): refused unread")
    with z.open(info) as f:
        data = f.read(limit + 1)
    if len(data) > limit:
        raise SnapshotError(f"{where}: {name} holds more than {limit} bytes: refused")
    return data


def read(path: Path) -> Snapshot:
    from .user_files import UserFileError, open_binary

    path = Path(path)
    try:
        f = open_binary(path, "snapshot")
    except UserFileError as err:
        raise SnapshotError(str(err)) from None
    try:
        with f:
            return _read_open(f, path)
    except OSError as err:
        raise SnapshotError(f"{path} cannot be read: {err.strerror or err}") from None


def _read_open(f, path: Path) -> Snapshot:
    try:
        with zipfile.ZipFile(f) as z:
            members = z.infolist()
            if len(members) > MAX_MEMBERS:
                raise SnapshotError(f"{path} holds {len(members)} files, more than a snapshot does ({MAX_MEMBERS})")
            manifest = json.loads(_read_member(z, "manifest.json", MAX_MANIFEST, path))
            if not isinstance(manifest, dict):
                raise SnapshotError(f"{path} is not a tiltload snapshot")
            check_manifest(manifest, path)
            declared = sum(z.getinfo(f"fmu/{name}.state").file_size for name in manifest["states"]
                           if f"fmu/{name}.state" in z.NameToInfo)
            if declared > MAX_STATES_TOTAL:
                raise SnapshotError(f"{path}: its states declare {declared} bytes, more than a snapshot holds "
                                    f"({MAX_STATES_TOTAL}): refused unread")
            states = {name: _read_member(z, f"fmu/{name}.state", MAX_STATE, path) for name in manifest["states"]}
    except SnapshotError:
        raise
    except zipfile.BadZipFile as err:
        if "CRC" in str(err):
            raise SnapshotError(f"{path} is damaged ({err})") from None
        raise SnapshotError(f"{path} is not a snapshot, or it is truncated (not a whole zip archive)") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as err:
        raise SnapshotError(f"{path}: its manifest is not JSON ({err})") from None
    except RecursionError:
        raise SnapshotError(f"{path}: its manifest is nested too deeply to be a snapshot's") from None
    except (OSError, EOFError, zlib.error, NotImplementedError, ValueError) as err:
        raise SnapshotError(f"{path} cannot be read: {err}") from None
    return Snapshot(manifest["tick"], manifest["ticks_done"], manifest["fingerprint"], states, manifest["values"],
                    manifest["delay_lines"], manifest["faults"], manifest["manipulator"], manifest["observers"],
                    manifest["application"])


def to_bytes(snap: Snapshot) -> bytes:
    """The snapshot as the bytes its file would hold (to ship it to campaign workers)."""
    import tempfile

    with tempfile.TemporaryDirectory(prefix="tiltload_snapshot_") as tmp:
        return write(snap, Path(tmp) / "s.snapshot").read_bytes()


def from_bytes(data: bytes, where: str = "the snapshot") -> Snapshot:
    """A snapshot file's bytes (as campaign workers receive them), read with the same checks and bounds as read()."""
    import io

    return _read_open(io.BytesIO(data), where)



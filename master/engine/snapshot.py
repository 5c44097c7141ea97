"""Snapshots of a running execution, and runs that continue from one as if never interrupted.

A snapshot holds every FMU's own serialized state (fmi2SerializeFMUstate) and the master's: the tick,
every instance's outputs as the engine holds them (after faults), the delay lines, the faults' state
and each observer's (metric integrals, the log's position in its cadence). A continued run loads the
same FMUs, initializes them, restores all of that and goes on from the next tick: its numbers and
its log are those of the uninterrupted run from there on, bit for bit.

On disk: one zip archive, manifest.json (the master's state as JSON: floats round-trip exactly) and
fmu/<instance>.state (the FMUs' bytes). The zip's CRCs catch a truncated or damaged file. A snapshot
carries a fingerprint of its system (instances, the FMUs' GUIDs, periods, timing, connections): a
snapshot of another system or another build is refused, naming what differs. No pickle: loading a
snapshot runs no code from it.
"""

from __future__ import annotations

import json
import zipfile
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import DescriptionError
from .model_description import checked_value

FORMAT = "tiltload-snapshot/1"
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


def fingerprint(execution) -> dict:
    """What must be the same for a snapshot to continue in this execution."""
    system = execution.system
    return {"tick": system.tick,
            "instances": [{"name": i.name, "guid": execution.model_descriptions[i.name].guid, "every": execution.every[i.name],
                           "timing": i.timing} for i in system.instances],
            "links": sorted([lk.source, lk.source_vr, lk.target, lk.target_vr, lk.type, lk.delay] for lk in execution.links)}


def take(execution, application: dict | None = None) -> Snapshot:
    """The execution's state between two ticks. Every FMU must be able to serialize its state."""
    from .manipulators import describe

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


def check(execution, snap: Snapshot) -> None:
    """Before anything is loaded: the snapshot is of this system and build, and its settings are tunable parameters."""
    check_compatible(snap.fingerprint, fingerprint(execution))
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
        slave.set_state(snap.states[name])
        for t, values in snap.values[name].items():
            slave.values[t][:] = np.asarray(values, dtype=_DTYPE[t])
    for name, values in snap.settings.items():  # a branch's own values of tunable parameters (checked already)
        execution.instances[name].set_values(values)
    execution.ticks_done, execution.time = snap.ticks_done, snap.time


def restore_loop(execution, snap: Snapshot) -> None:
    """The parts that live in the tick loop's plan and in the faults: after the plan is built."""
    from .manipulators import describe

    loop = execution.loop
    for name, lines in zip(loop.names, loop.delay_line()):
        for t, array in lines.items():
            array[:] = np.asarray(snap.delay_lines[name][t], dtype=array.dtype)
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


_REQUIRED = ("format", "tick", "ticks_done", "fingerprint", "values", "delay_lines", "faults", "manipulator", "observers",
             "application", "states")


def read(path: Path) -> Snapshot:
    path = Path(path)
    if not path.is_file():
        raise SnapshotError(f"snapshot {path} does not exist")
    try:
        with zipfile.ZipFile(path) as z:
            bad = z.testzip()
            if bad is not None:
                raise SnapshotError(f"{path} is damaged ({bad} fails its CRC)")
            manifest = json.loads(z.read("manifest.json"))
            if not isinstance(manifest, dict) or manifest.get("format") != FORMAT:
                raise SnapshotError(f"{path} is not a tiltload snapshot (format {manifest.get('format')!r}, expected {FORMAT})"
                                    if isinstance(manifest, dict) else f"{path} is not a tiltload snapshot")
            missing = [k for k in _REQUIRED if k not in manifest]
            if missing:
                raise SnapshotError(f"{path} is not a complete snapshot (no {', '.join(missing)})")
            states = {name: z.read(f"fmu/{name}.state") for name in manifest["states"]}
    except SnapshotError:
        raise
    except zipfile.BadZipFile:
        raise SnapshotError(f"{path} is not a snapshot, or it is truncated (not a whole zip archive)") from None
    except KeyError as err:
        raise SnapshotError(f"{path} is not a complete snapshot (no {err.args[0]})") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as err:
        raise SnapshotError(f"{path}: its manifest is not JSON ({err})") from None
    except (OSError, EOFError, zlib.error) as err:
        raise SnapshotError(f"{path} cannot be read: {err}") from None
    return Snapshot(manifest["tick"], manifest["ticks_done"], manifest["fingerprint"], states, manifest["values"],
                    manifest["delay_lines"], manifest["faults"], manifest["manipulator"], manifest["observers"],
                    manifest["application"])


def to_bytes(snap: Snapshot) -> bytes:
    """The snapshot as the bytes its file would hold (to ship it to campaign workers)."""
    import tempfile

    with tempfile.TemporaryDirectory(prefix="tiltload_snapshot_") as tmp:
        return write(snap, Path(tmp) / "s.snapshot").read_bytes()


def from_bytes(data: bytes) -> Snapshot:
    import tempfile

    with tempfile.TemporaryDirectory(prefix="tiltload_snapshot_") as tmp:
        path = Path(tmp) / "s.snapshot"
        path.write_bytes(data)
        return read(path)



"""The record of what ran, written into every log (its "run" and "fmus" metadata) and copied by baselines, and read back
here by every face: which case a run is, what differs between two of them said in one line, and which FMUs ran it
(each instance's model, GUID, SHA-256 and parameters).

A case is what decides a run's metrics: the vehicle, scenario, trajectory, controller, seed, stop time, the
--set parameters, the faults, the wind, the delay, the gusts and the schedule (or a system file). Where the FMUs
ran (in process, isolated, remote), the FMI version (the same metrics bit for bit, docs/fmi3.md) and what is
logged are not. A user's controller FMU is named by its file stem, not its path: the same controller checked out
elsewhere is the same case (and a changed controller is exactly what a regression test compares): so is a --set of
the controller's own parameters (changes.py says what changed in the controller before the comparison). A faults or
wind file is named by its stem and a digest of its content, so an edited file is another case.
"""

from __future__ import annotations

import hashlib
import shlex
from dataclasses import dataclass
from pathlib import Path

from ..loop.defaults import FMI, GUSTS, VEHICLE

# the keys compared, in the order a difference is told; with the value a record that lacks the key means (logs written
# before the key was recorded: no wind, the ordered schedule)
CASE_KEYS: dict[str, str | None] = {
    "system": "", "vehicle": VEHICLE, "scenario": None, "trajectory": None, "controller": None, "seed": None,
    "stop_time": None, "set": "", "faults": "", "wind": "", "delay": "False", "gusts": str(GUSTS), "schedule": "ordered",
}
UNDER_TEST = "controller"  # the instance a regression test changes: its settings are not the case
_LABELS = {"stop_time": "stop time", "set": "--set", "gusts": "gusts", "delay": "delay"}


def file_digest(path: Path | None) -> str:
    """The first 12 hex digits of a file's SHA-256 (empty for no file or one that cannot be read)."""
    if path is None:
        return ""
    try:
        return hashlib.sha256(Path(path).read_bytes()).hexdigest()[:12]
    except OSError:
        return ""


def record(*, scenario: str, trajectory: int | str, controller: str, seed: int, stop_time: float, vehicle: str = VEHICLE,
           delay: bool = False, gusts: bool = GUSTS, fmi: int = FMI, clocks: bool = False,
           settings: tuple[tuple[str, object], ...] = (), faults: Path | None = None, wind: Path | None = None,
           schedule: str = "ordered") -> dict[str, object]:
    """The "run" record of a run of the loop (the log's metadata keeps every value as text)."""
    meta: dict[str, object] = {"vehicle": vehicle, "scenario": scenario, "trajectory": trajectory, "controller": controller,
                               "seed": seed, "delay": delay, "gusts": gusts, "fmi": fmi, "clocks": clocks}
    if settings:
        meta["set"] = " ".join(f"{k}={v}" for k, v in settings)
    if faults is not None:
        meta["faults"], meta["faults_sha256"] = str(faults), file_digest(faults)
    if wind is not None:
        meta["wind"], meta["wind_sha256"] = str(wind), file_digest(wind)
    if schedule != "ordered":
        meta["schedule"] = schedule
    return {**meta, "stop_time": stop_time}


def identity(rec: dict) -> dict[str, str]:
    """The case of a record, key by key, as comparable text (a missing key: the value it meant when it was not recorded)."""
    out = {}
    for key, default in CASE_KEYS.items():
        value = rec.get(key, default)
        if value is None:
            continue  # not recorded (a log of an older tiltload): not compared
        value = str(value)
        if key == "controller" and value.endswith(".fmu"):
            value = Path(value).stem
        elif key in ("faults", "wind", "system") and value:
            digest = rec.get(f"{key}_sha256")
            value = Path(value).stem + (f" ({digest})" if digest else "")
        elif key == "set":
            value = " ".join(s for s in value.split() if not s.startswith(f"{UNDER_TEST}."))
        elif key == "stop_time":
            value = f"{float(value):g}"
        out[key] = value
    return out


def instance_settings(rec: dict, instance: str) -> str:
    """An instance's --set values in a record ("x_0=1.75 kp=2"), empty for none."""
    return " ".join(s.removeprefix(f"{instance}.") for s in str(rec.get("set", "")).split() if s.startswith(f"{instance}."))


def differences(a: dict, b: dict) -> list[str]:
    """What differs between two records' cases ("seed 3 vs 1"), in CASE_KEYS's order; empty for the same case."""
    ia, ib = identity(a), identity(b)
    out = []
    for key in CASE_KEYS:
        if key in ia and key in ib and ia[key] != ib[key]:
            unit = " s" if key == "stop_time" else ""
            out.append(f"{_LABELS.get(key, key)} {ia[key] or 'none'}{unit} vs {ib[key] or 'none'}{unit}")
    return out


def describe(rec: dict) -> str:
    """A case in words: "zse, trajectory 1, controller mixed, seed 1, stop time 10 s, delay"."""
    c = identity(rec)
    if c.get("system"):
        words = [f"system {c['system']}"]
    else:
        words = [("uav, " if c.get("vehicle") == "uav" else "") + c.get("scenario", "?"), f"trajectory {c.get('trajectory', '?')}",
                 f"controller {c.get('controller', '?')}", f"seed {c.get('seed', '?')}"]
    words.append(f"stop time {c.get('stop_time', '?')} s")
    words += [f"{k} {c[k]}" for k in ("set", "faults", "wind") if c.get(k)]
    words += ["delay"] * (c.get("delay") == "True") + ["calm"] * (c.get("gusts") == "False")
    words += [f"schedule {c['schedule']}"] * (c.get("schedule", "ordered") != "ordered")
    return ", ".join(words)


@dataclass(frozen=True)
class FmuRecord:
    """One FMU of the system under test: its instance name, model name, GUID (FMI 3.0: instantiation token), SHA-256."""

    instance: str
    model: str
    guid: str
    sha256: str
    path: str


def fmus_of_metadata(fmus: dict) -> tuple[tuple[FmuRecord, ...], tuple[tuple[str, str], ...]]:
    """The FMUs a log's "fmus" record names (engine.log.provenance.fmus_record), and the controller's parameters as the
    run set them; empty for a log that has none."""
    instances = [key.removesuffix(".fmu") for key in fmus if key.endswith(".fmu") and "." not in key.removesuffix(".fmu")]
    records = tuple(FmuRecord(i, str(fmus.get(f"{i}.model", "")), str(fmus.get(f"{i}.guid", "")),
                              str(fmus.get(f"{i}.sha256", "")), str(fmus.get(f"{i}.fmu", ""))) for i in instances)
    prefix = f"{UNDER_TEST}.param."
    parameters = tuple(sorted((k.removeprefix(prefix), str(v)) for k, v in fmus.items() if k.startswith(prefix)))
    return records, parameters


def fmus_of_system(system) -> tuple[tuple[FmuRecord, ...], tuple[tuple[str, str], ...]]:
    """The same of a system about to run (engine.system.System): each instance's FMU, and the controller instance's
    parameters (its FMU's start values, overridden by what the run sets)."""
    from ...engine.fmi.model_description import read_fmu
    from ...engine.log.provenance import fmu_digest

    fmus, params = [], {}
    for inst in system.instances:
        md = read_fmu(inst.fmu, inst.name)
        fmus.append(FmuRecord(inst.name, md.modelName, md.guid or "", fmu_digest(Path(inst.fmu)), str(inst.fmu)))
        if inst.name == UNDER_TEST:
            for v in md.modelVariables:
                if v.causality == "parameter":
                    params[v.name] = "" if v.start is None else str(v.start)
            params.update({k: str(v) for k, v in inst.parameters.items()})
    return tuple(fmus), tuple(sorted(params.items()))


# "run" record key -> the `tiltload run` option that sets it (flags: the value that turns them on)
_OPTIONS = (("vehicle", "--vehicle"), ("scenario", "--scenario"), ("trajectory", "--trajectory"),
            ("controller", "--controller"), ("seed", "--seed"), ("stop_time", "--stop-time"), ("faults", "--faults"),
            ("wind", "--wind"), ("schedule", "--schedule"), ("fmi", "--fmi"))
_FLAGS = (("delay", "True", "--delay"), ("gusts", "False", "--no-gusts"), ("clocks", "True", "--clocks"))


def replay_command(run: dict, requirements: Path | None = None) -> str:
    """The `tiltload run` command line of a log's "run" record, runnable as printed (a user's controller FMU by the
    path the run was given); empty for a record that names no case."""
    if run.get("system"):
        argv = ["tiltload", "run", "--system", str(run["system"]), "--stop-time", str(run.get("stop_time", ""))]
        if run.get("start_time"):
            argv += ["--start-time", str(run["start_time"])]
        if run.get("faults"):
            argv += ["--faults", str(run["faults"])]
    elif "scenario" in run:
        argv = ["tiltload", "run"]
        for key, option in _OPTIONS:
            value = run.get(key)
            if value not in (None, "") and not (key == "fmi" and str(value) == "2") and not (key == "vehicle" and value == VEHICLE):
                argv += [option, str(value)]
        argv += [flag for key, on, flag in _FLAGS if str(run.get(key, "")) == on]
        for setting in str(run.get("set", "")).split():
            argv += ["--set", setting]
    else:
        return ""
    if requirements is not None:
        argv += ["--requirements", str(requirements)]
    return shlex.join(argv)


def metrics_of_metadata(meta: dict) -> tuple[dict[str, float], int]:
    """A log's metrics record as numbers (the ISE and IADU by name), and the ticks it counts; a value that is no number
    is left out."""
    numbers = {}
    for key, value in (meta.get("metrics", {}) if isinstance(meta.get("metrics"), dict) else {}).items():
        try:
            numbers[key] = float(value)
        except ValueError:
            continue
    ticks = int(numbers.pop("ticks", 0))
    numbers.pop("complete", None)
    return numbers, ticks

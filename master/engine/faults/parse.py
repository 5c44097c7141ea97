"""Fault schedules read: the JSON form (checked against the schema, then for consistency), a fault file, a libcosim
scenario (events at times) as faults."""

from __future__ import annotations

from pathlib import Path

from .schedule import SCHEMA, TICK_ACTIONS, Fault, FaultError

NEEDS_VALUE = {"override", "bias", "scale", "ramp", "clamp", "noise", "delay", "stale", "jitter"}


def parse(items: list, where: str = "faults") -> list[Fault]:
    """Faults from their JSON form, checked against the schema and for consistency."""
    from ..user_files import schema_problem

    problem = schema_problem(items, SCHEMA, top="")
    if problem:
        raise FaultError(f"{where}.{problem}" if not problem.startswith(":") else f"{where}{problem}")
    faults = []
    for i, item in enumerate(items):
        targets = item.get("targets") or ([item["target"]] if "target" in item else [])
        if not targets:
            raise FaultError(f"{where}.{i}: name the faulty variable(s): target or targets")
        action, value = item["action"], item.get("value")
        if action in NEEDS_VALUE and value is None:
            raise FaultError(f"{where}.{i}: {action} needs a value")
        if action == "clamp" and not (isinstance(value, list) and len(value) == 2 and value[0] <= value[1]):
            raise FaultError(f"{where}.{i}: clamp takes value = [low, high]")
        if action in TICK_ACTIONS and not (isinstance(value, (int, float)) and 0 <= value <= 2**53 and float(value).is_integer()):
            raise FaultError(f"{where}.{i}: {action} takes a whole number of ticks (0 to 2^53), got {value!r}")
        if action not in TICK_ACTIONS | {"clamp"} and value is not None and not isinstance(value, (int, float)):
            raise FaultError(f"{where}.{i}: {action} takes a number, got {value!r}")
        if action == "dropout" and not item.get("flag"):
            raise FaultError(f"{where}.{i}: dropout needs the group's flag (e.g. sensors.gps_new)")
        end = item.get("end")
        if end is not None and end <= item["start"]:
            raise FaultError(f"{where}.{i}: end {end} must come after start {item['start']}")
        faults.append(Fault(action, targets, float(item["start"]), None if end is None else float(end), value,
                            item.get("flag"), int(item.get("seed", 0)), item.get("name", "")))
    return faults


def from_libcosim(scenario: dict, where: str) -> list[Fault]:
    """A libcosim scenario (events at times: override, bias, reset of model.variable) as faults."""
    defaults = scenario.get("defaults", {})
    events = scenario.get("events")
    if not isinstance(events, list):
        raise FaultError(f"{where}: a libcosim scenario has a list of events")
    open_faults: dict[str, Fault] = {}
    faults = []
    for i, event in enumerate(sorted(events, key=lambda e: e.get("time", 0))):
        e = {**defaults, **event}
        for key in ("time", "model", "variable", "action"):
            if key not in e:
                raise FaultError(f"{where}: events.{i}: no {key}")
        target = f"{e['model']}.{e['variable']}"
        if target in open_faults:  # a new event on the variable ends the previous one
            open_faults.pop(target).end = float(e["time"])
        if e["action"] == "reset":
            continue
        if e["action"] not in ("override", "bias"):
            raise FaultError(f"{where}: events.{i}: libcosim action {e['action']!r} is not override, bias or reset")
        value = e.get("value")
        if isinstance(value, str) and value.lower() in ("true", "false"):
            value = value.lower() == "true"
        f = Fault(e["action"], [target], float(e["time"]), None, float(value) if not isinstance(value, bool) else value,
                  name=f"libcosim {e['action']} {target}")
        open_faults[target] = f
        faults.append(f)
    end = scenario.get("end")
    for f in faults:
        if f.end is None and end is not None:
            f.end = float(end)
    return faults


def load(path: Path) -> list[Fault]:
    """A fault file: JSON or YAML, a list of faults, {"faults": [...]}, or a libcosim scenario."""
    from ..user_files import UserFileError, read_json, read_yaml

    path = Path(path)
    if not path.exists():
        raise FaultError(f"fault file {path} does not exist")
    try:
        data = read_yaml(path) if path.suffix.lower() in (".yaml", ".yml") else read_json(path)
    except UserFileError as err:
        raise FaultError(str(err)) from None
    if isinstance(data, dict) and "events" in data:
        return from_libcosim(data, str(path))
    if isinstance(data, dict) and "faults" in data:
        data = data["faults"]
    if not isinstance(data, list):
        raise FaultError(f"{path}: a fault file is a list of faults, {{\"faults\": [...]}} or a libcosim scenario")
    return parse(data, str(path))

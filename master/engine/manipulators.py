"""Manipulators: faults and timing faults injected between what an FMU outputs and what another one receives.

The engine's fourth part beside execution, algorithm and observers (libcosim's term). A fault acts
from `start` to `end` (s; no end: to the end of the run) on one or more variables:

- on an **output** (`instance.output`): the master's copy of it changes, so the log, the plots
  and every consumer see the faulty value (a lying or failed sensor, a drifting reference);
- on an **input** (`instance.input`): only what the master writes into that FMU changes (an
  actuator fault: `plant.f_R` scaled by 0.7 is a 30 % thrust loss; `plant.f_R_applied` logs it).

Actions and their `value`:
    override v       the value is v
    bias b           value + b
    scale s          value * s
    ramp r           value + r (t - start): a drift of r per second
    clamp [lo, hi]   value limited to [lo, hi] (a lower saturation limit)
    hold             the value at the start, held (a stuck sensor or actuator)
    noise sigma      value + sigma N(0, 1), seeded per tick (`seed`)
    dropout          the values hold and `flag` (a Boolean `instance.<group>_new`) stays false: a lost sensor
    delay n          the value of n ticks before (also list the flag among the targets to delay it too)
    stale n          the value of n ticks before, the flag untouched: old samples presented as new
    jitter n         the value of a random 0..n ticks before, drawn per tick (`seed`)

A schedule is a list of such faults, in a system description ("faults"), a campaign spec or a file
for `tiltload run --faults`. libcosim's scenario files (events at times: override, bias, reset)
are read too. Every fault's start and end is an observer event; the logger writes it on /faults.
"""

from __future__ import annotations

import ctypes
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import DescriptionError

ACTIONS = ("override", "bias", "scale", "ramp", "clamp", "hold", "noise", "dropout", "delay", "stale", "jitter")
VALUE_ACTIONS = ("override", "bias", "scale", "ramp", "clamp", "hold")  # functions of time and value only
NATIVE_LAG_LIMIT = 2**20  # ticks back the C loop's ring holds (8 MiB a target); a longer lag's history grows here
SEEDS = 2**64  # seeds are 0..SEEDS-1: the words the kernel's draws take (tl_draw.c)
_NEEDS_VALUE = {"override", "bias", "scale", "ramp", "clamp", "noise", "delay", "stale", "jitter"}
_TICKS = {"delay", "stale", "jitter"}

SCHEMA = {
    "type": "array", "items": {
        "type": "object", "additionalProperties": False, "required": ["action", "start"],
        "properties": {
            "name": {"type": "string"},
            "target": {"type": "string", "pattern": r"^[A-Za-z_][\w]*\.[A-Za-z_][\w]*$"},
            "targets": {"type": "array", "minItems": 1, "items": {"type": "string", "pattern": r"^[A-Za-z_][\w]*\.[A-Za-z_][\w]*$"}},
            "action": {"enum": list(ACTIONS)},
            "start": {"type": "number", "minimum": 0},
            "end": {"type": ["number", "null"], "minimum": 0},
            "value": {"type": ["number", "array", "boolean"]},
            "flag": {"type": "string", "pattern": r"^[A-Za-z_][\w]*\.[A-Za-z_][\w]*$"},
            "seed": {"type": "integer", "minimum": 0, "maximum": SEEDS - 1}}}}


class FaultError(DescriptionError):
    """A fault schedule that cannot be applied; the message names the fault and the field."""


@dataclass
class Fault:
    action: str
    targets: list[str]
    start: float
    end: float | None = None
    value: object = None
    flag: str | None = None
    seed: int = 0
    name: str = ""

    def label(self) -> str:
        return self.name or f"{self.action} {', '.join(self.targets)}"

    def active(self, t: float) -> bool:
        return self.start <= t + 1e-9 and (self.end is None or t + 1e-9 < self.end)


def parse(items: list, where: str = "faults") -> list[Fault]:
    """Faults from their JSON form, checked against the schema and for consistency."""
    from .user_files import schema_problem

    problem = schema_problem(items, SCHEMA, top="")
    if problem:
        raise FaultError(f"{where}.{problem}" if not problem.startswith(":") else f"{where}{problem}")
    faults = []
    for i, item in enumerate(items):
        targets = item.get("targets") or ([item["target"]] if "target" in item else [])
        if not targets:
            raise FaultError(f"{where}.{i}: name the faulty variable(s): target or targets")
        action, value = item["action"], item.get("value")
        if action in _NEEDS_VALUE and value is None:
            raise FaultError(f"{where}.{i}: {action} needs a value")
        if action == "clamp" and not (isinstance(value, list) and len(value) == 2 and value[0] <= value[1]):
            raise FaultError(f"{where}.{i}: clamp takes value = [low, high]")
        if action in _TICKS and not (isinstance(value, (int, float)) and 0 <= value <= 2**53 and float(value).is_integer()):
            raise FaultError(f"{where}.{i}: {action} takes a whole number of ticks (0 to 2^53), got {value!r}")
        if action not in _TICKS | {"clamp"} and value is not None and not isinstance(value, (int, float)):
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
    from .user_files import UserFileError, read_json, read_yaml

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


class _Direct:
    """An input no connection drives: the manipulator holds its value and sets it through the FMU's own setter."""

    def __init__(self, inst, variable) -> None:
        self.inst, self.type = inst, variable.type
        c_type = ctypes.c_double if variable.type == "Real" else ctypes.c_int
        self.buf = (c_type * 1)()
        self.view = np.ctypeslib.as_array(self.buf)
        self.vrs = (ctypes.c_uint * 1)(variable.valueReference)
        start = variable.start
        self.start = float(start) if variable.type == "Real" else (1 if str(start).lower() in ("true", "1") else 0)
        self.changed = False

    def write(self, active: bool) -> None:
        if not active:
            self.view[0] = self.start
        status = self.inst.setters[self.type](self.inst.component, self.vrs, 1, self.buf)
        if status > 1:
            raise self.inst.failed(f"set{self.type} by a fault", status)
        self.changed = active


class Manipulator:
    """Applies a fault schedule inside an Execution; tells the observers when faults start and end."""

    def __init__(self, faults: list[Fault]) -> None:
        self.faults = faults
        self._state = [False] * len(faults)
        self._held: dict[tuple[int, str], float] = {}
        self.native: set[int] = set()  # faults the C tick loop applies itself (native/loop.py); apply skips them

    def check(self, mds: dict, links) -> None:
        """Every target exists and can take its fault; FaultError naming the fault otherwise. From the model
        descriptions and the resolved connections alone, so a bad schedule is refused before any FMU loads."""
        fed = {(link.target, link.type, link.target_vr) for link in links}
        for f in self.faults:
            for target in f.targets + ([f.flag] if f.flag else []):
                instance, _, var = target.partition(".")
                if instance not in mds:
                    raise FaultError(f"fault {f.label()}: no instance '{instance}' (have: {', '.join(mds)})")
                v = next((x for x in mds[instance].modelVariables if x.name == var), None)
                if v is None:
                    raise FaultError(f"fault {f.label()}: {instance} has no variable '{var}'")
                if v.causality not in ("output", "input"):
                    raise FaultError(f"fault {f.label()}: {target} is a {v.causality}; faults act on outputs and inputs")
                if v.causality == "input" and (instance, v.type, v.valueReference) not in fed and v.type not in ("Real", "Boolean"):
                    raise FaultError(f"fault {f.label()}: {target} is an unconnected {v.type} input; faults set Real "
                                     "and Boolean ones")
                if f.action not in ("dropout", "delay", "stale", "jitter", "override") and v.type != "Real" and target != f.flag:
                    raise FaultError(f"fault {f.label()}: {f.action} needs a Real variable, {target} is {v.type}")

    def bind(self, execution) -> None:
        """Find every target (checked already) as an output or an input of the execution's instances."""
        self.outputs: dict[str, list[tuple[int, str]]] = {}  # instance -> (fault index, target) on its outputs
        self.inputs: dict[str, list[tuple[int, str]]] = {}
        self._where: dict[str, tuple] = {}
        for k, f in enumerate(self.faults):
            for target in f.targets + ([f.flag] if f.flag else []):
                instance, _, var = target.partition(".")
                inst = execution.instances[instance]
                v = inst.vars[var]
                if v.causality == "output":
                    self._where[target] = ("output", inst, v.type, inst.out_index[v.type][v.valueReference])
                    self.outputs.setdefault(instance, []).append((k, target))
                else:
                    group = next((g for g in execution.groups.get(instance, ()) if g.type == v.type
                                  and v.valueReference in list(g.dst_vrs)), None)
                    if group is not None:
                        self._where[target] = ("input", group, v.type, list(group.dst_vrs).index(v.valueReference))
                    else:  # an input nothing drives (e.g. plant.servo_R_stuck): the fault sets it itself
                        self._where[target] = ("direct", _Direct(inst, v), v.type, 0)
                    self.inputs.setdefault(instance, []).append((k, target))
        self._history: dict[str, list] = {t: [] for t in self._where}
        self._lags: dict[str, int] = {}  # the most ticks back any fault reads a target's history (dropout: 1)
        for f in self.faults:
            for target in f.targets:
                self._lags[target] = max(self._lags.get(target, 0), int(f.value) if f.action in _TICKS else 1)
        self._keep = {t: max(256, self._lags.get(t, 0) + 2) for t in self._where}
        self._tick = execution.system.tick
        self._draws = _Draws(self.faults)

    def python_entries(self, instance: str, side: str) -> bool:
        """Are there faults on this instance's side ("input" or "output") that Python applies?"""
        return any(k not in self.native for k, _ in (self.outputs if side == "output" else self.inputs).get(instance, ()))

    def native_capable(self, k: int, draws: bool = False) -> bool:
        """Can the C loop apply this fault, on its own terms? Its targets are connected inputs or outputs. Override,
        bias, scale, ramp, clamp and hold are functions of time and value; delay, stale and dropout read the
        target's history (Real targets; dropout's flag is set to false); noise and jitter also draw, when the
        kernel draws as numpy does (draws=True). Faults on unconnected inputs stay here."""
        f = self.faults[k]
        if f.action not in (*VALUE_ACTIONS, "delay", "stale", "dropout", *(("noise", "jitter") if draws else ())):
            return False
        if f.action in (*_TICKS, "dropout") and any(self._where[t][2] != "Real" for t in f.targets):
            return False
        if f.action in _TICKS and int(f.value) > NATIVE_LAG_LIMIT or f.action in ("noise", "jitter") and f.seed >= SEEDS:
            return False  # the ring is allocated whole; a Fault made in code may carry a seed the schema refuses
        return all(self._where[t][0] in ("input", "output") for t in _touched(f))

    def native_faults(self, draws: bool = False) -> set[int]:
        """The faults the C loop applies: those it can, less any that shares a target with one left to Python (the
        order of two faults on one target is then kept by applying both here)."""
        chosen = {k for k in range(len(self.faults)) if self.native_capable(k, draws)}
        while True:
            python_targets = {t for j, f in enumerate(self.faults) if j not in chosen for t in _touched(f)}
            kept = {k for k in chosen if python_targets.isdisjoint(_touched(self.faults[k]))}
            if kept == chosen:
                return chosen
            chosen = kept

    def lag(self, target: str) -> int:
        """The most ticks back a fault reads this target's history."""
        return self._lags.get(target, 0)

    def history_of(self, target: str) -> list[float]:
        """The target's true values, oldest first (what delays read)."""
        return self._history[target]

    def set_history_of(self, target: str, values) -> None:
        self._history[target] = [float(v) for v in values]

    def target(self, target: str):
        """(side, array the value is in, its index, type) of a bound target."""
        kind, owner, typ, index = self._where[target]
        return kind, (owner.values[typ] if kind == "output" else owner.view), index, typ

    def state_of(self, k: int, target: str) -> tuple[bool, float | None]:
        """(fault k active at the last look, the value it holds at target or None)."""
        return self._state[k], self._held.get((k, target))

    def set_state_of(self, k: int, on: bool, target: str, held: float | None) -> None:
        self._state[k] = on
        if held is not None:
            self._held[(k, target)] = held

    def snapshot_state(self) -> dict:
        """Where every fault stands: on or off, held values, the true values delays read, directly set inputs."""
        return {"on": list(self._state), "held": [[k, target, v] for (k, target), v in self._held.items()],
                "history": {t: list(h) for t, h in self._history.items()},
                "direct": {t: [float(w[1].view[0]), w[1].changed] for t, w in self._where.items() if w[0] == "direct"}}

    def restore_state(self, state: dict) -> None:
        self._state = [bool(x) for x in state["on"]]
        self._held = {(int(k), target): v for k, target, v in state["held"]}
        self._history = {t: list(h) for t, h in state["history"].items()}
        for target, (value, changed) in state["direct"].items():
            owner = self._where[target][1]
            owner.view[0], owner.changed = value, changed

    def _array(self, target: str, fresh: bool = False) -> tuple[np.ndarray, int]:
        kind, owner, typ, index = self._where[target]
        if kind == "direct" and fresh:
            owner.view[0] = owner.start  # the value the FMU has when no fault acts, once a tick: faults stack on it
        return (owner.values[typ] if kind == "output" else owner.view), index

    def apply(self, instance: str, side: str, t: float, observers) -> None:
        """Manipulate the instance's outputs just read (side "output") or inputs about to be set ("input")."""
        entries = [e for e in (self.outputs if side == "output" else self.inputs).get(instance, ()) if e[0] not in self.native]
        if not entries:
            return
        for target in dict.fromkeys(target for _, target in entries):  # the true values first, once a tick: delays read them
            arr, i = self._array(target, fresh=True)
            hist = self._history[target]
            hist.append(float(arr[i]))
            if len(hist) > self._keep[target] + 256:  # trimmed in steps, never below what the longest lag reads
                del hist[:-self._keep[target]]
        direct: dict[str, bool] = {}  # unconnected inputs: is any fault on it acting?
        for k, target in entries:
            f = self.faults[k]
            on = f.active(t)
            if on != self._state[k] and target == (f.targets + ([f.flag] if f.flag else []))[0]:
                self._state[k] = on
                for obs in observers:
                    obs.on_fault(t, f, "start" if on else "end")
            if on:
                self._apply_one(k, f, target, t)
            if self._where[target][0] == "direct":
                direct[target] = direct.get(target, False) or on
        for target, on in direct.items():  # set once, after every fault on it: while one acts, and once more to restore
            owner = self._where[target][1]
            if on or owner.changed:
                owner.write(on)

    def _apply_one(self, k: int, f: Fault, target: str, t: float) -> None:
        arr, i = self._array(target)
        hist = self._history[target]
        x = float(arr[i])
        a = f.action
        if target == f.flag:  # dropout: no new sample
            arr[i] = 0
            return
        if a == "override":
            arr[i] = float(f.value)
        elif a == "bias":
            arr[i] = x + float(f.value)
        elif a == "scale":
            arr[i] = x * float(f.value)
        elif a == "ramp":
            arr[i] = x + float(f.value) * (t - f.start)
        elif a == "clamp":
            arr[i] = min(max(x, float(f.value[0])), float(f.value[1]))
        elif a in ("hold", "dropout"):
            key = (k, target)
            if key not in self._held:  # the first tick of the fault; dropout keeps the sample the consumer already had
                self._held[key] = hist[-2] if a == "dropout" and len(hist) > 1 else x
            arr[i] = self._held[key]
        elif a == "noise":
            arr[i] = x + float(f.value) * self._draws.normal(k, int(round(t / self._tick)))
        elif a in ("delay", "stale", "jitter"):
            n = int(f.value)
            if a == "jitter":
                n = self._draws.bounded(k, int(round(t / self._tick)), n)
            arr[i] = hist[max(len(hist) - 1 - n, 0)]


def _touched(f: Fault) -> list[str]:
    """The variables a fault writes: its targets and its flag."""
    return f.targets + ([f.flag] if f.flag else [])


class _Draws:
    """The draws of noise and jitter: those of numpy's default_rng([seed, fault, tick]), a pure function of the three
    (the same with any batching, after a snapshot, in any worker). Made by the kernel's C (tl_draw.c, equal to numpy
    bit for bit, 30-45x cheaper than seeding a Generator) when it has them, else by numpy."""

    def __init__(self, faults: list[Fault]) -> None:
        from .native import kernel

        self.seeds = [f.seed for f in faults]
        self.lib = kernel.library() if kernel.draws_in_c() and all(f.seed < SEEDS for f in faults) else None
        if self.lib is not None:
            self.words = []
            for k, f in enumerate(faults):
                words = kernel.entropy_words(f.seed, k)
                self.words.append(((ctypes.c_uint32 * len(words))(*words), len(words)))

    def normal(self, k: int, tick: int) -> float:
        if self.lib is None:
            return float(np.random.default_rng([self.seeds[k], k, tick]).standard_normal())
        return self.lib.tl_draw_normal(*self.words[k], tick)

    def bounded(self, k: int, tick: int, n: int) -> int:
        """An integer in 0..n"""
        if self.lib is None:
            return int(np.random.default_rng([self.seeds[k], k, tick]).integers(0, n + 1))
        return int(self.lib.tl_draw_bounded(*self.words[k], tick, n))


def describe(fault: Fault) -> dict:
    value = fault.value
    if isinstance(value, float) and not math.isfinite(value):
        value = str(value)
    return {"name": fault.label(), "action": fault.action, "targets": fault.targets, "start": fault.start,
            "end": fault.end, "value": value, "flag": fault.flag}

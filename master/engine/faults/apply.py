"""The manipulator: a fault schedule applied inside an Execution, between what an FMU outputs and what another one
receives, telling the observers when faults start and end (libcosim's term for the engine's fourth part)."""

from __future__ import annotations

import ctypes

import numpy as np

from .draw import Draws
from .schedule import SEEDS, TICK_ACTIONS, VALUE_ACTIONS, Fault, FaultError

NATIVE_LAG_LIMIT = 2**20  # ticks back the C loop's ring holds (8 MiB a target); a longer lag's history grows here


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
                if v.type in ("String", "Binary"):  # not in the engine's arrays (texts.py sets them)
                    raise FaultError(f"fault {f.label()}: {target} is a {v.type}; faults act on numbers and Booleans")
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
                self._lags[target] = max(self._lags.get(target, 0), int(f.value) if f.action in TICK_ACTIONS else 1)
        self._keep = {t: max(256, self._lags.get(t, 0) + 2) for t in self._where}
        self._tick = execution.system.tick
        self._draws = Draws(self.faults)

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
        if f.action in (*TICK_ACTIONS, "dropout") and any(self._where[t][2] != "Real" for t in f.targets):
            return False
        if f.action in TICK_ACTIONS and int(f.value) > NATIVE_LAG_LIMIT or f.action in ("noise", "jitter") and f.seed >= SEEDS:
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


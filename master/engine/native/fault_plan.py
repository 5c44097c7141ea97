"""The faults' part of the C loop's plan (loop.py): the faults the kernel applies itself, one entry per target and flag,
with their delay rings and noise seeds; the callbacks for those Python applies; and the fault state carried between the
kernel and the manipulator for a snapshot (sync_faults, push_faults)."""

from __future__ import annotations

import ctypes

import numpy as np

from . import kernel
from .codes import Side, value_type

SIDES = {"input": Side.INPUTS, "output": Side.OUTPUTS}  # the manipulator's sides


def _entropy(fault, k: int) -> dict:
    """The noise or jitter fault's seed words: [seed, k] as numpy's SeedSequence reads them (faults/draw.py draws
    from default_rng([seed, k, tick]))."""
    if fault.action not in ("noise", "jitter"):
        return {}
    words = kernel.entropy_words(fault.seed, k)
    return {"n_entropy": len(words), "entropy": (ctypes.c_uint32 * kernel.ENTROPY_WORDS)(*words)}


class FaultPlan:
    """NativeLoop's fault planning (a part of the plan, in a module of its own): it reads the loop's ex, plan, chunk,
    instances and _index, and sets the fault arrays the kernel and _batch read."""

    def _plan_faults(self, manipulator) -> None:
        """The faults' part of the plan: the kernel's own (_native_faults) and the callbacks for those Python applies."""
        self._faulted = manipulator is not None
        self._fault_keep: list = []  # the delay rings of these faults: replaced with them
        self._native_faults(manipulator, self._index)
        for spec, c in zip(self.ex.system.instances, self.instances):  # the faults Python applies: a callback there
            c.hook_inputs = bool(manipulator and manipulator.python_entries(spec.name, "input"))
            c.hook_outputs = bool(manipulator and manipulator.python_entries(spec.name, "output"))

    def _native_faults(self, manipulator, index: dict[str, int]) -> None:
        """The faults the kernel applies itself (manipulator.native_faults), one entry per target and flag."""
        ops, self._fault_targets, self._report_side = [], [], {}
        if manipulator is not None:
            manipulator.native = manipulator.native_faults(kernel.draws_in_c())
            for k in sorted(manipulator.native):
                f = manipulator.faults[k]
                for j, target in enumerate(f.targets + ([f.flag] if f.flag else [])):
                    side, array, i, typ = manipulator.target(target)
                    action = "override" if target == f.flag else f.action  # dropout: its flag held false
                    value = 0.0 if target == f.flag else f.value if f.action != "clamp" else f.value[0]
                    ops.append(kernel.Fault(instance=index[target.partition(".")[0]], side=SIDES[side],
                                            action=kernel.FAULT_ACTIONS[action], type=value_type(typ),
                                            array=array.ctypes.data, index=i,
                                            value=float(value) if value is not None else 0.0,
                                            high=float(f.value[1]) if f.action == "clamp" else 0.0, start=f.start,
                                            end=f.end if f.end is not None else float("inf"), fault=k, reports=j == 0,
                                            **_entropy(f, k),
                                            **self._history(f, manipulator.lag(target)) if target != f.flag else {}))
                    self._fault_targets.append((k, target))
                    self._report_side.setdefault(k, SIDES[side])
        self.faults = (kernel.Fault * max(len(ops), 1))(*ops)
        self.fault_on = np.zeros(max(len(manipulator.faults) if manipulator else 0, 1), dtype=np.int8)
        capacity = self.chunk * 2 * max(len(ops), 1)
        self.event_record = np.zeros(capacity, dtype=np.int64)
        self.event_fault = np.zeros(capacity, dtype=np.int32)
        self.event_start = np.zeros(capacity, dtype=np.int8)
        self.event_time = np.zeros(capacity, dtype=np.float64)
        p = self.plan
        p.n_faults, p.faults, p.fault_on, p.event_capacity = len(ops), self.faults, self.fault_on.ctypes.data, capacity
        p.event_record, p.event_fault = self.event_record.ctypes.data, self.event_fault.ctypes.data
        p.event_start, p.event_time = self.event_start.ctypes.data, self.event_time.ctypes.data

    def _history(self, fault, lag: int) -> dict:
        """delay, stale, jitter, dropout: a ring of the target's true values, as deep as its longest lag"""
        if fault.action not in ("delay", "stale", "jitter", "dropout"):
            return {}
        ring = np.zeros(lag + 1, dtype=np.float64)
        self._fault_keep.append(ring)
        return {"history": ring.ctypes.data, "history_capacity": ring.size}

    def sync_faults(self) -> None:
        """The kernel's fault state into the manipulator (on/off, held values, the histories delays read), for a
        snapshot."""
        m = self.ex.manipulator
        for op, (k, target) in zip(self.faults, self._fault_targets):
            m.set_state_of(k, bool(self.fault_on[k]), target, op.held if op.holding else None)
            if op.history:
                ring = np.ctypeslib.as_array((ctypes.c_double * op.history_capacity).from_address(op.history))
                m.set_history_of(target, np.roll(ring, -op.history_next)[op.history_capacity - op.history_count:])

    def push_faults(self) -> None:
        """The manipulator's fault state into the kernel (a run continued from a snapshot)."""
        m = self.ex.manipulator
        for op, (k, target) in zip(self.faults, self._fault_targets):
            on, held = m.state_of(k, target)
            self.fault_on[k] = on
            if held is not None:
                op.holding, op.held = 1, held
            if op.history:
                values = m.history_of(target)[-op.history_capacity:]
                ring = np.ctypeslib.as_array((ctypes.c_double * op.history_capacity).from_address(op.history))
                ring[:len(values)] = values
                op.history_count, op.history_next = len(values), len(values) % op.history_capacity

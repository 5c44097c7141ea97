"""Observers: read-only views of an execution (metrics, progress). The MCAP logger is in mcap_log.py.

An observer sees the execution start, every instance's outputs after each of its steps (with the
time they hold), the end of every tick, the start and end of every fault, and the finish.
"""

from __future__ import annotations

import sys
import time

import numpy as np


class Observer:
    def start(self, execution) -> None: ...

    def on_step(self, instance, t: float) -> None: ...

    def on_tick(self, k: int, t: float) -> None: ...

    def on_fault(self, t: float, fault, what: str) -> None: ...  # what: "start" or "end" (manipulators.py)

    def finish(self, execution, error: str | None) -> None: ...


def _real(instance, name: str) -> int:
    for i, v in enumerate(instance.outputs["Real"]):
        if v.name == name:
            return i
    raise KeyError(f"{instance.name} has no Real output '{name}'")


class Metrics(Observer):
    """ISE of tracked variables and IADU of the actuators of a feedback loop, sampled on the tick.

    ISE(v) = sum_k (v(t_k) - v_ref(t_k))^2 T and IADU(u) = sum_k |u_k - u_{k-1}|, the discrete forms
    of the integrals. The plant's value at t_k is its output before the tick's step. plant, reference
    and actuators are instance names; tracked pairs a plant output with a reference output; inputs
    names the actuator instance's command outputs.
    """

    def __init__(self, plant: str, reference: str, actuators: str, tracked: tuple[tuple[str, str], ...],
                 inputs: tuple[str, ...]) -> None:
        self.plant, self.reference, self.actuators = plant, reference, actuators
        self.tracked, self.inputs = tracked, inputs
        self._ise = np.zeros(len(tracked))
        self._iadu = np.zeros(len(inputs))
        self._prev_u = None
        self.ticks = 0

    @property
    def ise(self) -> dict[str, float]:
        return {f"ISE({a})": float(v) for (a, _), v in zip(self.tracked, self._ise)}

    @property
    def iadu(self) -> dict[str, float]:
        return {f"IADU({u})": float(v) for u, v in zip(self.inputs, self._iadu)}

    def start(self, execution) -> None:
        self.tick = execution.system.tick
        ins = execution.instances
        self._p = ins[self.plant]
        self._r = ins[self.reference]
        self._a = ins[self.actuators]
        self._pi = np.array([_real(self._p, a) for a, _ in self.tracked])
        self._ri = np.array([_real(self._r, r) for _, r in self.tracked])
        self._ui = np.array([_real(self._a, u) for u in self.inputs])
        self._x = self._p.values["Real"][self._pi]  # the plant's value at the start of the tick (a copy: fancy index)

    def on_step(self, instance, t) -> None:
        if instance is self._a:  # u_k and ref(t_k) are known, the plant has not stepped yet
            e = self._x - self._r.values["Real"][self._ri]
            self._ise += e * e * self.tick
            u = self._a.values["Real"][self._ui]
            if self._prev_u is not None:
                self._iadu += np.abs(u - self._prev_u)
            self._prev_u = u
        elif instance is self._p:
            self._x = self._p.values["Real"][self._pi]

    def table(self) -> dict[str, float]:
        return {**self.ise, **self.iadu}


class Progress(Observer):
    """A one-line progress bar on stderr, refreshed at most twice a second."""

    def __init__(self, stop: float, stream=sys.stderr) -> None:
        self.stop, self.stream = stop, stream
        self._t0 = time.perf_counter()
        self._last = self._t0  # first refresh after 0.5 s, when the rate means something

    def on_tick(self, k, t) -> None:
        now = time.perf_counter()
        if now - self._last < 0.5 and t < self.stop:
            return
        self._last = now
        frac = min(t / self.stop, 1.0)
        bar = "#" * int(30 * frac)
        self.stream.write(f"\r  [{bar:<30}] {100 * frac:5.1f} %  t = {t:6.2f} s  ({t / max(now - self._t0, 1e-9):.0f}x real time)")
        self.stream.flush()

    def finish(self, execution, error) -> None:
        self.stream.write("\n")
        self.stream.flush()

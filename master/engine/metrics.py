"""The loop's metrics observer: ISE and IADU over the tick loop's batches, walked in C (native/tl_metrics.c); the
campaign's extras (campaign/metrics.py) ride on the same walk."""

from __future__ import annotations

from functools import cache
from pathlib import Path

import numpy as np

from .observers import Batch, Observer, real_outputs


def _real(instance, name: str) -> int:
    i = real_outputs(instance).get(name)
    if i is None:
        raise KeyError(f"{instance.name} has no Real output '{name}'")
    return i


class Metrics(Observer):
    """ISE of tracked variables and IADU of the actuators of a feedback loop, sampled on the tick.

    ISE(v) = sum_k (v(t_k) - v_ref(t_k))^2 T and IADU(u) = sum_k |u_k - u_{k-1}|, the discrete forms
    of the integrals. The plant's value at t_k is its output before the tick's step. plant, reference
    and actuators are instance names; tracked pairs a plant output with a reference output; inputs
    names the actuator instance's command outputs. The sums run in the order of the steps (one addition a step,
    not a pairwise sum), so they do not depend on how the steps were batched. A batch is walked in C
    (native/tl_metrics.c): numpy's dozens of calls a batch cost a 2 s campaign run 0.11 ms.
    """

    def __init__(self, plant: str, reference: str, actuators: str, tracked: tuple[tuple[str, str], ...],
                 inputs: tuple[str, ...]) -> None:
        self.plant, self.reference, self.actuators = plant, reference, actuators
        self.tracked, self.inputs = tracked, inputs
        self._sums = np.zeros(len(tracked) + len(inputs))  # ISE, then IADU
        self._counts = np.zeros(4, dtype=np.int64)  # a previous command is held, steps, saturated, contained
        self._worst = np.zeros(1)  # the largest tracking error after the settling time (the campaign's)
        self._carry = None  # set at start: x, ref, the previous command, the plant's state (the campaign's)

    @property
    def ise(self) -> dict[str, float]:
        return {f"ISE({a})": float(v) for (a, _), v in zip(self.tracked, self._sums[:len(self.tracked)])}

    @property
    def iadu(self) -> dict[str, float]:
        return {f"IADU({u})": float(v) for u, v in zip(self.inputs, self._sums[len(self.tracked):])}

    def _extras(self, execution) -> tuple[np.ndarray, np.ndarray | None, tuple[float, ...]]:
        """The campaign's: the plant's state columns, the actuators' bound columns (lower then upper; None: no
        bounds), (settle, lo, hi, tau, eps). None: ISE and IADU only."""
        return None

    def start(self, execution) -> None:
        self.tick = execution.system.tick
        ins = execution.instances
        self._p, self._r, self._a = ins[self.plant], ins[self.reference], ins[self.actuators]
        pi = [_real(self._p, a) for a, _ in self.tracked]
        ri = [_real(self._r, r) for _, r in self.tracked]
        ui = [_real(self._a, u) for u in self.inputs]
        extras = self._extras(execution)
        state, bounds, limits = extras if extras is not None else (np.zeros(0, dtype=np.int64), None, (0.0,) * 5)
        self._cols = np.array([*pi, *ri, *ui, *state, *(bounds if bounds is not None else ())], dtype=np.int64)
        self._sizes = np.array([len(pi), len(ui), len(state), bounds is not None, extras is not None], dtype=np.int64)
        self._limits = np.array([self.tick, *limits])
        prev = self._a.values["Real"][ui]
        self._carry = np.concatenate([self._p.values["Real"][pi], self._r.values["Real"][ri], prev,
                                      self._p.values["Real"][state]])
        if getattr(execution, "resumed_at", None) is not None:  # from a snapshot: the first step's change is from the command held there
            self._counts[0] = 1
        self._who = None  # the instances' places among a batch's names, at the first batch
        self._fixed = tuple(a.ctypes.data for a in (self._sizes, self._cols))

    def on_batch(self, execution, batch: Batch) -> None:
        if batch.closing:  # the samples at the run's end (edges.py) start no tick: the sums run over [0, T)
            return
        if self._who is None or self._who[1] is not batch.names:
            names = batch.names
            self._who = (np.array([names.index(self.plant), names.index(self.reference), names.index(self.actuators)],
                                  dtype=np.int64), names)
        rows = batch.rows
        p, r, a = (np.ascontiguousarray(rows[name]["Real"]) for name in (self.plant, self.reference, self.actuators))
        failed = _metrics_kernel()(len(batch.instance), batch.instance.ctypes.data, batch.row.ctypes.data,
                                   batch.time.ctypes.data, self._who[0].ctypes.data, *self._fixed, p.ctypes.data,
                                   p.shape[1], r.ctypes.data, r.shape[1], a.ctypes.data, a.shape[1],
                                   self._limits.ctypes.data, self._sums.ctypes.data, self._carry.ctypes.data,
                                   self._counts.ctypes.data, self._worst.ctypes.data)
        if failed:
            raise ValueError(f"the metrics kernel refused the loop's {len(self.tracked)} tracked outputs and "
                             f"{len(self.inputs)} commands")

    def table(self) -> dict[str, float]:
        return {**self.ise, **self.iadu}

    def _carried(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        k, m = len(self.tracked), len(self.inputs)
        c = self._carry
        return c[:k], c[k:2 * k], c[2 * k:2 * k + m], c[2 * k + m:]

    def snapshot_state(self) -> dict:
        x, ref, prev, _ = self._carried()
        k = len(self.tracked)
        return {"ise": self._sums[:k].tolist(), "iadu": self._sums[k:].tolist(), "x": x.tolist(), "ref": ref.tolist(),
                "prev_u": prev.tolist() if self._counts[0] else None}

    def restore_state(self, state: dict) -> None:
        k = len(self.tracked)
        self._sums[:k], self._sums[k:] = state["ise"], state["iadu"]
        x, ref, prev, _ = self._carried()
        x[:], ref[:] = state["x"], state["ref"]
        self._counts[0] = state["prev_u"] is not None
        if state["prev_u"] is not None:
            prev[:] = state["prev_u"]


@cache
def _metrics_kernel():
    """native/tl_metrics.c, compiled like the engine's kernel."""
    import ctypes

    from .native.kernel import CFLAGS, compiled

    fn = compiled("tl_metrics", (Path(__file__).parent / "native" / "tl_metrics.c",), CFLAGS, ("m",)).tl_metrics_batch
    n, p = ctypes.c_int64, ctypes.c_void_p
    fn.argtypes = [n, p, p, p, p, p, p, p, n, p, n, p, n, p, p, p, p, p]
    fn.restype = n
    return fn

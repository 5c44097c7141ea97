"""The campaign's metrics observer: the loop's ISE and IADU, the worst tracking error, the share of ticks with an
actuator at its limit and the ZSE's containment; a run's row of them."""

from __future__ import annotations

import math

import numpy as np

from ...engine.observers import Metrics, real_outputs
from ..loop import COMMANDS, CONTROLLER, PLANT, SCENARIO, TRACKED


class CampaignMetrics(Metrics):
    """ISE and IADU, plus the worst tracking error (after `settle` s: the runs start 30 cm off the path), the share of
    ticks with an actuator at its limit and, in the ZSE scenario, the share of ticks with the true state in the bounds."""

    def __init__(self, limits=(0.0, 30.0, 2.0), bounds: bool = True, settle: float = 5.0) -> None:
        super().__init__(PLANT, SCENARIO, CONTROLLER, TRACKED, COMMANDS)
        self.settle = settle  # the worst tracking error counts after the initial offset is taken up
        self.limits = limits
        self.bounds = bounds  # the controller's est_*_lo/hi are an estimator's set (the ZSE scenario)
        self.max_error = 0.0
        self.saturated = 0
        self.contained = 0
        self.controller_steps = 0
        self._lo = self._hi = None  # set at start (a run that fails at initialization never starts)

    def start(self, execution) -> None:
        super().start(execution)
        plant, ctrl = self._p, self._a
        names = [v.name for v in plant.outputs["Real"]][:20]
        ctrl_names = real_outputs(ctrl)
        self._state_index = np.arange(20)
        has_bounds = self.bounds and all(f"est_{n}_lo" in ctrl_names and f"est_{n}_hi" in ctrl_names for n in names)
        self._lo = np.array([ctrl_names[f"est_{n}_lo"] for n in names]) if has_bounds else None
        self._hi = np.array([ctrl_names[f"est_{n}_hi"] for n in names]) if has_bounds else None
        self._state = plant.values["Real"][self._state_index]

    def on_batch(self, execution, batch) -> None:
        at, e, u = self._sampled(batch)
        if len(at):
            late = batch.time[at] >= self.settle
            if late.any():
                position = e[late, :3]
                self.max_error = max(self.max_error, float(np.sqrt((position * position).sum(axis=1)).max()))
            lo, hi, tau = self.limits
            eps = 1e-9
            thrust = u[:, :2]
            self.saturated += int(np.count_nonzero(((thrust <= lo + eps) | (thrust >= hi - eps)).any(axis=1)
                                                   | (np.abs(u[:, 2:]) >= tau - eps).any(axis=1)))
            if self._lo is not None:
                state = self._carried(batch, self.plant, self._state_index, self._state)
                v = batch.rows[self.actuators]["Real"][batch.row[at]]
                self.contained += int(np.count_nonzero(np.all((v[:, self._lo] <= state) & (state <= v[:, self._hi]), axis=1)))
            self.controller_steps += len(at)
        plant_rows = batch.rows[self.plant]["Real"]
        if len(plant_rows):
            self._state = plant_rows[-1, self._state_index]
        self._accumulate(batch, at, e, u)

    def snapshot_state(self) -> dict:
        return {**super().snapshot_state(), "max_error": self.max_error, "saturated": self.saturated,
                "contained": self.contained, "controller_steps": self.controller_steps, "state": self._state.tolist()}

    def restore_state(self, state: dict) -> None:
        super().restore_state(state)
        self.max_error, self.saturated = state["max_error"], state["saturated"]
        self.contained, self.controller_steps = state["contained"], state["controller_steps"]
        self._state = np.array(state["state"])

    def row(self, keep: tuple[str, ...]) -> dict[str, float]:
        out = {}
        if "ISE" in keep:
            out.update(self.ise)
        if "IADU" in keep:
            out.update(self.iadu)
        if "max_tracking_error" in keep:
            out["max_tracking_error"] = self.max_error
        if "time_saturated" in keep:
            out["time_saturated"] = self.saturated / max(self.controller_steps, 1)
        if "zse_containment" in keep:
            out["zse_containment"] = self.contained / self.controller_steps if self._lo is not None and self.controller_steps else math.nan
        return out

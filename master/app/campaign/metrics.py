"""The campaign's metrics observer: the loop's ISE and IADU, the worst tracking error, the share of ticks with an
actuator at its limit and the ZSE's containment; a run's row of them."""

from __future__ import annotations

import math

import numpy as np

from ....plant_fmu.parameters import ACTUATOR_LIMIT
from ...engine.metrics import Metrics
from ...engine.observers import real_outputs
from ..loop.thesis import COMMANDS, CONTROLLER, PLANT, SCENARIO, TRACKED


class CampaignMetrics(Metrics):
    """ISE and IADU, plus the worst tracking error (after `settle` s: the runs start 30 cm off the path), the share of
    ticks with an actuator at its limit and, in the ZSE scenario, the share of ticks with the true state in the bounds."""

    def __init__(self, limits=tuple(ACTUATOR_LIMIT[k] for k in ("f_min", "f_max", "tau_max")), bounds: bool = True,
                 settle: float = 5.0) -> None:
        super().__init__(PLANT, SCENARIO, CONTROLLER, TRACKED, COMMANDS)
        self.settle = settle  # the worst tracking error counts after the initial offset is taken up
        self.limits = limits
        self.bounds = bounds  # the controller's est_*_lo/hi are an estimator's set (the ZSE scenario)
        self._has_bounds = False  # set at start (a run that fails at initialization never starts)

    def _extras(self, execution):
        plant, ctrl = execution.instances[PLANT], execution.instances[CONTROLLER]
        names = [v.name for v in plant.outputs["Real"]][:20]
        ctrl_names = real_outputs(ctrl)
        self._has_bounds = self.bounds and all(f"est_{n}_lo" in ctrl_names and f"est_{n}_hi" in ctrl_names for n in names)
        bounds = ([ctrl_names[f"est_{n}_lo"] for n in names] + [ctrl_names[f"est_{n}_hi"] for n in names]
                  if self._has_bounds else None)
        lo, hi, tau = self.limits
        return np.arange(len(names)), bounds, (self.settle, lo, hi, tau, 1e-9)

    @property
    def max_error(self) -> float:
        return float(self._worst[0])

    @property
    def saturated(self) -> int:
        return int(self._counts[2])

    @property
    def contained(self) -> int:
        return int(self._counts[3])

    @property
    def controller_steps(self) -> int:
        return int(self._counts[1])

    def snapshot_state(self) -> dict:
        return {**super().snapshot_state(), "max_error": self.max_error, "saturated": self.saturated,
                "contained": self.contained, "controller_steps": self.controller_steps,
                "state": self._carried()[3].tolist()}

    def restore_state(self, state: dict) -> None:
        super().restore_state(state)
        self._worst[0] = state["max_error"]
        self._counts[1:] = state["controller_steps"], state["saturated"], state["contained"]
        self._carried()[3][:] = state["state"]

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
            out["zse_containment"] = self.contained / self.controller_steps if self._has_bounds and self.controller_steps else math.nan
        return out

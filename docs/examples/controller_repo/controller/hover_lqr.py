"""The controller of this example repository: LQR state feedback on the exact state, tracking the reference.

Its tests (tests/test_hover_lqr.py) run it against tiltload's loop through the tiltload pytest plugin, which wraps
it as an FMU (as `tiltload wrap controller/hover_lqr.py` does) once per session.

The gain is computed once, when the FMU is initialized, with tiltload's public design namespace
(tl.plant, tl.design: docs/design_api.md), so this example needs tiltload in the Python that runs
the FMU; any controller of yours can do anything in __init__ and step.
"""

import numpy as np
import tiltload as tl

STATES = tl.plant.trim().state_names  # x, y, z, phi, ..., alpha_L, then their rates x_dot, ...


class HoverLQR:
    """LQR on the exact state, tracking x_ref, y_ref, z_ref."""

    inputs = [f"exact_{s}" for s in STATES] + ["x_ref", "y_ref", "z_ref"]
    parameters = {"position_weight": 10.0}
    period = 0.012

    def __init__(self, position_weight=10.0):
        model = tl.plant.linearize(dt=self.period)  # at the hover trim, zero-order hold at the controller's period
        Q = np.eye(20)
        Q[:3, :3] *= position_weight
        self.K = tl.design.dlqr(model, Q, np.eye(4)).K
        self.x_eq, self.u_eq = model.trim.x, model.trim.u
        self.limits = tl.plant.limits()  # Table 5.2: what the plant saturates to

    def step(self, t, inputs):
        x = np.array([inputs[f"exact_{s}"] for s in STATES]) - self.x_eq
        x[:3] -= [inputs["x_ref"], inputs["y_ref"], inputs["z_ref"]]
        u = self.u_eq - self.K @ x
        return self.limits.clip(u).tolist()

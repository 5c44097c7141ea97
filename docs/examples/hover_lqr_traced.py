"""hover_lqr.py with a parameter that stays tunable in C: `tiltload wrap --native` makes it a C FMU that runs without
Python (Linux, Windows, aarch64; FMI 2.0 and 3.0), written in plain numpy (no CasADi):

    tiltload wrap --native docs/examples/hover_lqr_traced.py --out runs/hover_lqr_traced.fmu
    tiltload run --controller runs/hover_lqr_traced.fmu --scenario fsi --trajectory 0 --set controller.position_scale=1.2

__init__ runs at wrap time in Python and may do anything (here the design with tl.plant and tl.design); its numbers
(K, x_eq, u_eq, u_min, u_max) become the FMU's parameters. What it derives from a declared parameter with numpy
(here the gain's position columns scaled by position_scale) is traced, so setting the parameter on the FMU recomputes
it. step is traced: numpy's arithmetic, @, assignment into arrays and tl.saturate; no Python decision on a value
(docs/ports.md, "A native FMU from Python").
"""

import numpy as np
import tiltload as tl

STATES = tl.plant.trim().state_names


class HoverLQRTraced:
    """LQR on the exact state, tracking x_ref, y_ref, z_ref; saturated to Table 5.2's limits."""

    inputs = [f"exact_{s}" for s in STATES] + ["x_ref", "y_ref", "z_ref"]
    parameters = {"position_scale": 1.0}
    period = 0.012

    def __init__(self, position_scale=1.0):
        model = tl.plant.linearize(dt=self.period)
        Q = np.eye(20)
        Q[:3, :3] *= 10.0
        scale = np.ones(20)
        scale[:3] = position_scale  # the position feedback scaled: recomputed in C when the parameter is set
        self.K = tl.design.dlqr(model, Q, np.eye(4)).K * scale
        self.x_eq, self.u_eq = model.trim.x, model.trim.u
        limits = tl.plant.limits()  # Table 5.2
        self.u_min = np.array([limits.f_min, limits.f_min, -limits.tau_max, -limits.tau_max])
        self.u_max = np.array([limits.f_max, limits.f_max, limits.tau_max, limits.tau_max])

    def step(self, t, inputs):
        x = np.array([inputs[f"exact_{s}"] for s in STATES]) - self.x_eq
        x[:3] -= np.array([inputs["x_ref"], inputs["y_ref"], inputs["z_ref"]])
        u = self.u_eq - self.K @ x
        return [float(v) for v in tl.saturate(u, self.u_min, self.u_max)]

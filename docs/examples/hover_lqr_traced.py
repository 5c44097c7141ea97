"""hover_lqr.py written with traceable operations, so `tiltload wrap --native` makes it a C FMU that runs without
Python (Linux, Windows, aarch64; FMI 2.0 and 3.0):

    tiltload wrap --native docs/examples/hover_lqr_traced.py --out runs/hover_lqr_traced.fmu
    tiltload run --controller runs/hover_lqr_traced.fmu --scenario fsi --trajectory 0

__init__ runs once, at wrap time, in Python: it may do anything (here the design with tl.plant and tl.design); its
numbers (K, x_eq, u_eq, u_min, u_max) become the FMU's parameters. step is traced: arithmetic, @ and casadi's
fmin/fmax for the saturation, no Python decision on a value (docs/ports.md, "A native FMU from Python").
"""

import casadi as ca
import numpy as np
import tiltload as tl

STATES = tl.plant.trim().state_names


class HoverLQRTraced:
    """LQR on the exact state, tracking x_ref, y_ref, z_ref; saturated to Table 5.2's limits."""

    inputs = [f"exact_{s}" for s in STATES] + ["x_ref", "y_ref", "z_ref"]
    parameters = {"position_weight": 10.0}
    period = 0.012

    def __init__(self, position_weight=10.0):
        model = tl.plant.linearize(dt=self.period)
        Q = np.eye(20)
        Q[:3, :3] *= position_weight
        self.K = tl.design.dlqr(model, Q, np.eye(4)).K
        self.x_eq, self.u_eq = model.trim.x, model.trim.u
        limits = tl.plant.limits()  # Table 5.2
        self.u_min = np.array([limits.f_min, limits.f_min, -limits.tau_max, -limits.tau_max])
        self.u_max = np.array([limits.f_max, limits.f_max, limits.tau_max, limits.tau_max])

    def step(self, t, inputs):
        x = np.array([inputs[f"exact_{s}"] for s in STATES]) - self.x_eq
        x[:3] -= np.array([inputs["x_ref"], inputs["y_ref"], inputs["z_ref"]])
        u = self.u_eq - self.K @ x
        return [ca.fmin(ca.fmax(u[i], self.u_min[i]), self.u_max[i]) for i in range(4)]

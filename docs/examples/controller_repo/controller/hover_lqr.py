"""The controller of this example repository: LQR state feedback on the exact state, tracking the reference.

Its tests (tests/test_hover_lqr.py) run it against tiltload's loop through the tiltload pytest plugin, which wraps
it as an FMU (as `tiltload wrap controller/hover_lqr.py` does) once per session.

The gain is computed once, when the FMU is initialized, from tiltload's own linearization (so
this example needs tiltload in the Python that runs the FMU); any controller of yours can do
anything in __init__ and step.
"""

import numpy as np

STATES = ["x", "y", "z", "phi", "theta", "psi", "gamma_1", "gamma_2", "alpha_R", "alpha_L"]
STATES += [f"{s}_dot" for s in STATES]


class HoverLQR:
    """LQR on the exact state, tracking x_ref, y_ref, z_ref."""

    inputs = [f"exact_{s}" for s in STATES] + ["x_ref", "y_ref", "z_ref"]
    parameters = {"position_weight": 10.0}
    period = 0.012

    def __init__(self, position_weight=10.0):
        from scipy.linalg import solve_discrete_are
        from tiltload.controller_fmu.design.estimator_setup import augmented_model

        m = augmented_model(self.period)
        A, B = m.A[:20, :20], m.B[:20]
        Q = np.eye(20)
        Q[:3, :3] *= position_weight
        P = solve_discrete_are(A, B, Q, np.eye(4))
        self.K = np.linalg.solve(B.T @ P @ B + np.eye(4), B.T @ P @ A)
        self.x_eq, self.u_eq = m.trim.x, m.trim.u

    def step(self, t, inputs):
        x = np.array([inputs[f"exact_{s}"] for s in STATES]) - self.x_eq
        x[:3] -= [inputs["x_ref"], inputs["y_ref"], inputs["z_ref"]]
        u = self.u_eq - self.K @ x
        return np.clip(u[:2], 0.0, 30.0).tolist() + np.clip(u[2:], -2.0, 2.0).tolist()

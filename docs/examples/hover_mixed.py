"""An example controller for `tiltload wrap`: the thesis's mixed H2/H-infinity gain (LMI pole regions) on the exact
state, with integral action, following the reference's position and velocity.

    tiltload wrap docs/examples/hover_mixed.py --out runs/hover_mixed.fmu
    tiltload run --controller runs/hover_mixed.fmu --scenario fsi --trajectory 1
    tiltload run --controller runs/hover_mixed.fmu --scenario fsi --trajectory 1 --delay --set controller.delay_ticks=1

The gain comes from tl.design.mixed (docs/design_api.md): the design tiltload ships, checked on this machine's model
when the FMU is initialized. With delay_ticks = 1 it is the design for a loop whose command reaches the plant one tick
late (`--delay`), and the controller feeds back the command still on its way, as the model it was designed on says.
There is no feedforward here (the thesis's (3.18)): the trim's inputs and the integral action hold the load.
"""

import numpy as np
import tiltload as tl

STATES = tl.plant.trim().state_names
REGULATED = [STATES.index(s) for s in ("x", "y", "z", "psi")]  # the integral states' errors, in chi's order


class HoverMixed:
    """u = u_trim - K chi, chi = [x - x_ref, the integrals of the x, y, z, psi errors, the commands on their way]."""

    inputs = [f"exact_{s}" for s in STATES] + ["x_ref", "y_ref", "z_ref", "vx_ref", "vy_ref", "vz_ref", "psi_ref"]
    parameters = {"delay_ticks": 0.0}
    period = tl.plant.TICK  # the shipped designs' sample time

    def __init__(self, delay_ticks=0.0):
        design = tl.design.mixed(delay_ticks=int(delay_ticks))
        self.K = design.K
        self.x_eq, self.u_eq = design.model.trim.x, design.model.trim.u
        self.limits = tl.plant.limits()
        self.integral = np.zeros(4)
        self.on_the_way = [np.zeros(4)] * design.model.delay_ticks  # the deviations of the last commands, oldest first

    def step(self, t, inputs):
        x = np.array([inputs[f"exact_{s}"] for s in STATES])
        x_ref = self.x_eq.copy()  # the load on the reference, everything else at the trim
        x_ref[REGULATED] = [inputs["x_ref"], inputs["y_ref"], inputs["z_ref"], inputs["psi_ref"]]
        x_ref[[STATES.index(s) for s in ("x_dot", "y_dot", "z_dot")]] = [inputs["vx_ref"], inputs["vy_ref"], inputs["vz_ref"]]
        error = x - x_ref
        chi = np.concatenate([error, self.integral, *self.on_the_way])
        u = self.limits.clip(self.u_eq - self.K @ chi)
        self.integral = self.integral + self.period * error[REGULATED]
        if self.on_the_way:
            self.on_the_way = [*self.on_the_way[1:], u - self.u_eq]
        return u.tolist()

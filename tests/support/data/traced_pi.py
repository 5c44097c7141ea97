"""A controller with a state (an integral with anti-windup by ca.if_else) and a saturation by ca.fmin/ca.fmax: what a
traced step must carry between ticks (tests/app/test_wrap_native.py)."""

import casadi as ca
import numpy as np


class TracedPI:
    """PI on the altitude error, the integral held between ticks and frozen while the thrust saturates."""

    inputs = ["exact_z", "z_ref", "exact_z_dot"]
    parameters = {"kp": 4.0, "ki": 1.5}
    period = 0.024

    def __init__(self, kp=4.0, ki=1.5):
        self.gains = np.array([kp, ki, 2.5])  # kp, ki, kd
        self.hover = 10.2
        self.integral = 0.0
        self.limits = np.array([0.0, 30.0])

    def step(self, t, inputs):
        e = inputs["z_ref"] - inputs["exact_z"]
        raw = self.hover + self.gains[0] * e + self.gains[1] * self.integral - self.gains[2] * inputs["exact_z_dot"]
        thrust = ca.fmin(ca.fmax(raw, self.limits[0]), self.limits[1])
        self.integral = ca.if_else(raw == thrust, self.integral + e * self.period, self.integral)
        wobble = 0.01 * ca.sin(2 * np.pi * t)
        return [thrust + wobble, thrust - wobble, 0.0, 0.0]

"""Controllers written in plain numpy, as control engineers write them (no CasADi): each must become a native FMU
unchanged and equal its Python form (tests/app/test_plain_numpy.py). All stabilize hover with one LQR gain, each
with its own way of writing saturations, choices, conversions, states and gains."""

import math

import numpy as np
import tiltload as tl

STATES = tl.plant.trim().state_names
EXACT = [f"exact_{s}" for s in STATES]
REFS = ["x_ref", "y_ref", "z_ref"]
_MODEL = tl.plant.linearize(dt=0.012)
K = tl.design.dlqr(_MODEL, np.diag([10.0] * 3 + [1.0] * 17), np.eye(4)).K
X_EQ, U_EQ = _MODEL.trim.x, _MODEL.trim.u
LIMITS = tl.plant.limits()
LO = np.array([LIMITS.f_min, LIMITS.f_min, -LIMITS.tau_max, -LIMITS.tau_max])
HI = np.array([LIMITS.f_max, LIMITS.f_max, LIMITS.tau_max, LIMITS.tau_max])


class _Lqr:
    inputs = EXACT + REFS
    period = 0.012

    def __init__(self):
        self.K = K.copy()
        self.x_eq, self.u_eq = X_EQ.copy(), U_EQ.copy()

    def error(self, inputs):
        x = np.array([inputs[n] for n in EXACT]) - self.x_eq
        x[:3] -= np.array([inputs[r] for r in REFS])
        return x

    def raw(self, inputs):
        return self.u_eq - self.K @ self.error(inputs)


class ClipFloat(_Lqr):
    def step(self, t, inputs):
        u = self.raw(inputs)
        return (float(np.clip(u[0], 0, 30)), float(np.clip(u[1], 0, 30)), float(np.clip(u[2], -5, 5)),
                float(np.clip(u[3], -5, 5)))


class LimitsClip(_Lqr):
    def __init__(self):
        super().__init__()
        self.limits = tl.plant.limits()

    def step(self, t, inputs):
        return self.limits.clip(self.raw(inputs)).tolist()


class MinMax(_Lqr):
    def step(self, t, inputs):
        return np.minimum(np.maximum(self.raw(inputs), LO), HI)


class NestedWhere(_Lqr):
    def step(self, t, inputs):
        u = self.raw(inputs)
        return np.where(u > HI, HI, np.where(u < LO, LO, u))


class AsarrayFloat(_Lqr):
    def step(self, t, inputs):
        x = np.asarray([inputs[n] for n in EXACT], dtype=float) - self.x_eq
        ref = np.asarray([inputs[r] for r in REFS], dtype=float)
        x = np.concatenate([x[:3] - ref, x[3:]])
        return list(np.clip(self.u_eq - self.K @ x, LO, HI))


class StackAndSlices(_Lqr):
    def step(self, t, inputs):
        x = self.error(inputs)
        pos, rest = x[:3], x[3:]
        both = np.stack([pos, pos * 0.0])
        x = np.hstack([both[0], rest])
        u = self.u_eq - self.K[:, :3] @ x[:3] - self.K[:, 3:] @ x[3:]
        return tuple(np.clip(u, LO, HI))


class AssignInto(_Lqr):
    def step(self, t, inputs):
        raw = self.raw(inputs)
        u = np.zeros(4)
        u[:2] = np.clip(raw[:2], LO[0], HI[0])
        u[2] = min(HI[2], 5.0) * np.tanh(raw[2] / 5.0)
        u[3] = np.clip(raw[3], LO[3], HI[3])
        return u


class IntegratorHeld(_Lqr):
    parameters = {"ki": 0.5}

    def __init__(self, ki=0.5):
        super().__init__()
        self.ki = ki
        self.integral = 0.0

    def step(self, t, inputs):
        e = inputs["z_ref"] - inputs["exact_z"]
        u = self.raw(inputs)
        u[:2] = u[:2] + self.ki * self.integral
        saturated = (u[0] >= HI[0]) | (u[0] <= LO[0])
        self.integral = np.where(saturated, self.integral, self.integral + e * self.period)
        return np.clip(u, LO, HI)


class RateLimitHelper(_Lqr):
    def __init__(self):
        super().__init__()
        self.previous = self.u_eq.copy()

    def step(self, t, inputs):
        self.previous = tl.rate_limit(self.raw(inputs), self.previous, np.array([0.5, 0.5, 0.05, 0.05]))
        return tl.saturate(self.previous, LO, HI)


class RateLimitByHand(_Lqr):
    def __init__(self):
        super().__init__()
        self.last = self.u_eq.copy()

    def step(self, t, inputs):
        du = np.clip(self.raw(inputs) - self.last, -0.4, 0.4)
        self.last = self.last + du
        return [float(v) for v in np.clip(self.last, LO, HI)]


class DeadZoneHelper(_Lqr):
    def step(self, t, inputs):
        x = self.error(inputs)
        x[:3] = tl.dead_zone(x[:3], 0.002)
        return tl.saturate(self.u_eq - self.K @ x, LO, HI)


class ChooseHelper(_Lqr):
    def step(self, t, inputs):
        u = self.raw(inputs)
        far = np.abs(inputs["z_ref"] - inputs["exact_z"]) > 0.2
        return tl.choose(far, np.clip(u, LO, HI), tl.saturate(u, LO + 0.5 * (U_EQ - LO), HI))


class MathYaw(_Lqr):
    def step(self, t, inputs):
        x = self.error(inputs)
        c, s = math.cos(inputs["exact_psi"]), math.sin(inputs["exact_psi"])
        ex, ey = c * x[0] + s * x[1], -s * x[0] + c * x[1]
        x[0], x[1] = c * ex - s * ey, s * ex + c * ey  # rotated there and back: the same error, through math
        return np.clip(self.u_eq - self.K @ x, LO, HI) + math.sqrt(1e-6) * 0.0


class AbsSign(_Lqr):
    def step(self, t, inputs):
        e = inputs["z_ref"] - inputs["exact_z"]
        u = self.raw(inputs)
        boost = 0.05 * np.sign(e) * np.minimum(np.abs(e), 0.1)
        return np.clip(u + np.array([boost, boost, 0.0, 0.0]), LO, HI)


class GainsFromInit(_Lqr):
    parameters = {"position_scale": 1.0, "thrust_trim": 0.0}

    def __init__(self, position_scale=1.0, thrust_trim=0.0):
        super().__init__()
        scale = np.ones(20)
        scale[:3] = position_scale
        self.K = K * scale  # a gain derived from the parameter: recomputed when it is set
        self.u_eq = U_EQ + np.array([thrust_trim, thrust_trim, 0.0, 0.0])

    def step(self, t, inputs):
        return np.clip(self.raw(inputs), LO, HI)


class CommandFilter(_Lqr):
    parameters = {"alpha": 0.8}

    def __init__(self, alpha=0.8):
        super().__init__()
        self.alpha = alpha
        self.filtered = U_EQ.copy()

    def step(self, t, inputs):
        self.filtered = self.alpha * self.filtered + (1 - self.alpha) * self.raw(inputs)
        return np.clip(self.filtered, LO, HI)


class TimeOffset(_Lqr):
    def step(self, t, inputs):
        x = self.error(inputs)
        x[2] = x[2] - 0.01 * np.sin(2 * np.pi * 0.5 * t)
        return np.clip(self.u_eq - self.K @ x, LO, HI)


class IntOfTime(_Lqr):
    def step(self, t, inputs):
        stair = int(t / 0.5)  # a staircase reference: int() truncates
        x = self.error(inputs)
        x[2] = x[2] + 0.001 * stair
        return np.clip(self.u_eq - self.K @ x, LO, HI)


class Transposed(_Lqr):
    def __init__(self):
        super().__init__()
        self.KT = K.T.copy()

    def step(self, t, inputs):
        u = self.u_eq - self.error(inputs) @ self.KT
        return np.clip(u, LO, HI)


class NormScaled(_Lqr):
    def step(self, t, inputs):
        x = self.error(inputs)
        far = np.linalg.norm(x[:2])
        x[:2] = x[:2] / (1.0 + far)
        return np.clip(self.u_eq - self.K @ x, LO, HI)


class TanhPosition(_Lqr):
    def step(self, t, inputs):
        x = self.error(inputs)
        x[:3] = 0.5 * np.tanh(x[:3] / 0.5)
        return np.clip(self.u_eq - self.K @ x, LO, HI)


class BudgetByMax(_Lqr):
    def step(self, t, inputs):
        du = self.raw(inputs) - self.u_eq
        scale = np.minimum(1.0, 4.0 / np.maximum(np.max(np.abs(du)), 1e-9))
        return np.clip(self.u_eq + scale * du, LO, HI)


class PythonLoop(_Lqr):
    def step(self, t, inputs):
        u = self.raw(inputs)
        return [float(np.clip(u[i], LO[i], HI[i])) for i in range(4)]


class SumAndMean(_Lqr):
    def step(self, t, inputs):
        u = self.raw(inputs)
        common = np.mean(u[:2])
        diff = (u[0] - u[1]) / 2
        total = np.sum(np.array([common, diff]))  # = u[0]
        return np.clip(np.array([total, common - diff, u[2], u[3]]), LO, HI)


CORPUS = [ClipFloat, LimitsClip, MinMax, NestedWhere, AsarrayFloat, StackAndSlices, AssignInto, IntegratorHeld,
          RateLimitHelper, RateLimitByHand, DeadZoneHelper, ChooseHelper, MathYaw, AbsSign, GainsFromInit,
          CommandFilter, TimeOffset, IntOfTime, Transposed, NormScaled, TanhPosition, BudgetByMax, PythonLoop,
          SumAndMean]

"""The sensor suite of the thesis as sample-and-hold channels (Sec. 5.3, Table 5.8). Numpy only: the FMU runs it.

Each group samples every `period` (a whole number of ticks), adds noise from its own random
stream (seeded by the suite seed and the group's index, so changing one sensor never changes
another's noise), raises its `new` flag for that tick and holds the sample in between.
Gaussian bounds are 3 sigma (Table 5.8); uniform noise is uniform on [-bound, bound].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

PDFS = ("gaussian", "uniform")
ZSE_NAMES = ("x_B", "y_B", "z_B", "phi_B", "theta_B", "psi_B", "p_B", "q_B", "r_B",
             "d_BL_x", "d_BL_y", "d_BL_z", "alpha_R", "alpha_L", "alpha_R_dot", "alpha_L_dot")


@dataclass(frozen=True)
class Group:
    name: str
    source: str  # "q" (LKF scenario) or "pi" (ZSE scenario)
    indices: tuple[int, ...]  # entries of q or of pi(x)
    period: float
    bound: float | tuple[float, ...]  # one per entry, or one for all
    pdf: str
    unit: str


# (name, source, indices, period s, bound, pdf, unit): Sec. 5.3 and Table 5.8
GROUPS = (
    Group("lkf", "q", tuple(range(10)), 0.012, (0.15,) * 3 + (0.0,) * 7, "gaussian", "m, rad"),
    Group("gps", "pi", (0, 1), 0.120, 0.15, "gaussian", "m"),
    Group("baro", "pi", (2,), 0.012, 0.51, "gaussian", "m"),
    Group("imu_att", "pi", (3, 4, 5), 0.012, 2.618e-3, "gaussian", "rad"),
    Group("imu_rate", "pi", (6, 7, 8), 0.012, 16.558e-3, "gaussian", "rad/s"),
    Group("cam_xy", "pi", (9, 10), 0.024, 0.005, "uniform", "m"),
    Group("cam_z", "pi", (11,), 0.024, 0.02, "uniform", "m"),
    Group("servo_angle", "pi", (12, 13), 0.012, 5.67e-3, "uniform", "rad"),
    Group("servo_rate", "pi", (14, 15), 0.012, 0.50772, "uniform", "rad/s"),
)


class SensorError(ValueError):
    """A sensor set-up that cannot be sampled; the message says which parameter."""


def check(step: float, periods, bounds, pdfs) -> list[int]:
    """Ticks per sample of every group; raises SensorError naming the first bad parameter."""
    if not (np.isfinite(step) and step > 0):
        raise SensorError(f"step must be a positive finite time, got {float(step)!r}")
    ticks = []
    for g, period, bound, pdf in zip(GROUPS, periods, bounds, pdfs):
        if not (np.isfinite(period) and period > 0):
            raise SensorError(f"{g.name}_period must be positive and finite, got {float(period)!r}")
        n = round(period / step)
        if n < 1 or abs(n * step - period) > 1e-9 * max(period, step):
            raise SensorError(f"{g.name}_period = {float(period)!r} s is not a whole multiple of the step {float(step)!r} s")
        b = np.atleast_1d(bound)
        if not (np.all(np.isfinite(b)) and np.all(b >= 0)):
            raise SensorError(f"{g.name} bound must be non-negative and finite, got {np.asarray(bound).tolist()}")
        if pdf not in PDFS:
            raise SensorError(f"{g.name}_pdf must be one of {', '.join(PDFS)}, got {pdf!r}")
        ticks.append(n)
    return ticks


class SensorSuite:
    """Samples all groups on tick k from the true state's q and pi(x)."""

    def __init__(self, seed: int, step: float, periods, bounds, pdfs) -> None:
        self.ticks = check(step, periods, bounds, pdfs)
        self.bounds = [np.broadcast_to(np.asarray(b, dtype=float), (len(g.indices),)).copy() for g, b in zip(GROUPS, bounds)]
        self.pdfs = list(pdfs)
        self.rngs = [np.random.default_rng([int(seed) & 0xFFFFFFFF, i]) for i in range(len(GROUPS))]
        self.values = [np.zeros(len(g.indices)) for g in GROUPS]
        self.new = [False] * len(GROUPS)

    def sample(self, k: int, q: np.ndarray, pi_x: np.ndarray) -> None:
        for i, g in enumerate(GROUPS):
            self.new[i] = k % self.ticks[i] == 0
            if not self.new[i]:
                continue
            truth = (q if g.source == "q" else pi_x)[list(g.indices)]
            rng, b = self.rngs[i], self.bounds[i]
            noise = rng.normal(0.0, 1.0, b.size) * (b / 3.0) if self.pdfs[i] == "gaussian" else rng.uniform(-1.0, 1.0, b.size) * b
            self.values[i] = truth + noise

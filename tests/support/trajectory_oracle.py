"""Independent reference for the scenario FMU: Sec. 5.1.2's trajectories with hand-derived derivatives, and the gusts.

The FMU's C is generated from CasADi position expressions (derivatives by automatic
differentiation, scenario_fmu/trajectories.py); this file writes velocity and acceleration
out by hand, so the two agree only if both are right.
"""

from __future__ import annotations

import math

import numpy as np

PI = math.pi
DURATION = {1: 40.0, 2: 50.0}  # s: one circle; Table 5.3 ends with the landing at t = 50 s
START = {1: (1.7, 0.3, 0.7), 2: (0.3, -0.3, 0.0)}  # the load's initial position (30 cm off the path)


def circle(t: float) -> np.ndarray:
    """Trajectory 1: x = 2 cos(pi t/20), y = 2 sin(pi t/20), z = 9 - 8 cos(pi t/20)."""
    w = PI / 20
    c, s = math.cos(w * t), math.sin(w * t)
    return np.array([[2 * c, 2 * s, 9 - 8 * c],
                     [-2 * w * s, 2 * w * c, 8 * w * s],
                     [-2 * w * w * c, -2 * w * w * s, 8 * w * w * c]])


def _table_5_3(t: float) -> np.ndarray:
    """Trajectory 2, Table 5.3 (spiral take-off, lines with rounded corners, landing)."""
    h = PI / 2  # corner rate
    q = PI / 4  # line speed
    if t < 10:
        a, da = 0.01 * t * t, 0.02 * t  # x = a cos(q t)
        cx, sx = math.cos(q * t), math.sin(q * t)
        x = (a * cx, da * cx - a * q * sx, 0.02 * cx - 2 * da * q * sx - a * q * q * cx)
        b, db, ddb = math.sin(PI * t / 20), PI / 20 * math.cos(PI * t / 20), -(PI / 20) ** 2 * math.sin(PI * t / 20)
        y = (b * sx, db * sx + b * q * cx, ddb * sx + 2 * db * q * cx - b * q * q * sx)
        w = PI / 10
        z = (2.5 - 2.5 * math.cos(w * t), 2.5 * w * math.sin(w * t), 2.5 * w * w * math.cos(w * t))
    elif t < 19:
        x, y, z = (-q * (t - 10), -q, 0.0), (1.0, 0.0, 0.0), (5.0, 0.0, 0.0)
    elif t < 20:
        s, c = math.sin(h * (t - 19)), math.cos(h * (t - 19))
        x = (-9 * PI / 4 - 0.5 * s, -0.5 * h * c, 0.5 * h * h * s)
        y = (1.5 - 0.5 * c, 0.5 * h * s, 0.5 * h * h * c)
        z = (5.0, 0.0, 0.0)
    elif t < 29:
        x, y, z = (-9 * PI / 4 - 0.5, 0.0, 0.0), (1.5 + q * (t - 20), q, 0.0), (5.0, 0.0, 0.0)
    elif t < 30:
        s, c = math.sin(h * (t - 29)), math.cos(h * (t - 29))
        x = (-9 * PI / 4 - 0.5 * c, 0.5 * h * s, 0.5 * h * h * c)
        y = (1.5 + 9 * PI / 4 + 0.5 * s, 0.5 * h * c, -0.5 * h * h * s)
        z = (5.0, 0.0, 0.0)
    elif t < 40:
        x, y, z = (-9 * PI / 4 + q * (t - 30), q, 0.0), (2 + 9 * PI / 4, 0.0, 0.0), (5.0, 0.0, 0.0)
    else:
        w = PI / 10
        x = (-PI / 80 * t * t + 5 * PI / 4 * t - 119 * PI / 4, -PI / 40 * t + 5 * PI / 4, -PI / 40)
        y = (2 + 9 * PI / 4, 0.0, 0.0)
        z = (2.5 + 2.5 * math.cos(w * (t - 40)), -2.5 * w * math.sin(w * (t - 40)), -2.5 * w * w * math.cos(w * (t - 40)))
    return np.array([x, y, z]).T


def reference(trajectory: int, t: float) -> np.ndarray:
    """3 x 3: rows position, velocity, acceleration; trajectory 0 is hover at the origin."""
    if trajectory == 0:
        return np.zeros((3, 3))
    if trajectory == 1:
        return circle(t)
    if trajectory == 2:
        return _table_5_3(t)
    raise ValueError(f"unknown trajectory {trajectory} (available: 0 hover, 1 circle, 2 Table 5.3)")


def gust(t: float, onset: float, magnitude: float, tau: float) -> float:
    """A step of magnitude at onset through a first-order lag tau (exact solution, no integration error)."""
    if t < onset:
        return 0.0
    return magnitude * (1.0 - math.exp(-(t - onset) / tau)) if tau > 0 else magnitude

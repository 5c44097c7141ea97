"""Reference trajectories of Sec. 5.1.2 (and of Appendix A, for the UAV alone) and the wind gusts of
Sec. 5.1.3, written once in CasADi.

Only positions are written; velocity and acceleration are their exact time derivatives by
automatic differentiation. The scenario FMU runs the C that CasADi generates from these
expressions (psi_tr = 0 throughout, as in the thesis). tests/support/trajectory_oracle.py is an
independent hand-derived version.
"""

from __future__ import annotations

import math

import casadi as ca

PI = math.pi
DURATION = {1: 40.0, 2: 50.0, 3: 80.0}  # s: one circle; Table 5.3 ends with the landing at t = 50 s
# the initial position: the load's, 30 cm off the path (1, 2); the UAV's of Appendix A, x0 = (3.9, 0.1, 0.9) (3)
START = {1: (1.7, 0.3, 0.7), 2: (0.3, -0.3, 0.0), 3: (3.9, 0.1, 0.9)}


def circle(t: ca.SX) -> list[ca.SX]:
    """Trajectory 1: x = 2 cos(pi t/20), y = 2 sin(pi t/20), z = 9 - 8 cos(pi t/20)."""
    w = PI / 20
    return [2 * ca.cos(w * t), 2 * ca.sin(w * t), 9 - 8 * ca.cos(w * t)]


def appendix_a(t: ca.SX) -> list[ca.SX]:
    """Trajectory 3, the UAV alone (Sec. A.4): x = 4 cos(pi t/40), y = 4 sin(pi t/40), z = 17 - 16 cos(pi t/40)
    (one circle in 80 s)."""
    w = PI / 40
    return [4 * ca.cos(w * t), 4 * ca.sin(w * t), 17 - 16 * ca.cos(w * t)]


def table_5_3(t: ca.SX) -> list[ca.SX]:
    """Trajectory 2, Table 5.3: spiral take-off, lines with rounded corners, landing."""
    h, q, w = PI / 2, PI / 4, PI / 10  # corner rate, line speed, climb rate
    pieces = [  # (end of the piece, x, y, z); the last piece has no end
        (10, 0.01 * t**2 * ca.cos(q * t), ca.sin(PI * t / 20) * ca.sin(q * t), 2.5 - 2.5 * ca.cos(w * t)),
        (19, -q * (t - 10), 1, 5),
        (20, -9 * PI / 4 - 0.5 * ca.sin(h * (t - 19)), 1.5 - 0.5 * ca.cos(h * (t - 19)), 5),
        (29, -9 * PI / 4 - 0.5, 1.5 + q * (t - 20), 5),
        (30, -9 * PI / 4 - 0.5 * ca.cos(h * (t - 29)), 1.5 + 9 * PI / 4 + 0.5 * ca.sin(h * (t - 29)), 5),
        (40, -9 * PI / 4 + q * (t - 30), 2 + 9 * PI / 4, 5),
        (None, -PI / 80 * t**2 + 5 * PI / 4 * t - 119 * PI / 4, 2 + 9 * PI / 4, 2.5 + 2.5 * ca.cos(w * (t - 40))),
    ]
    *middle, (_, *last) = pieces
    position = [ca.SX(v) for v in last]
    for end, *xyz in reversed(middle):
        position = [ca.if_else(t < end, ca.SX(v), p) for v, p in zip(xyz, position)]
    return position


def gust(t: ca.SX, onset: ca.SX, magnitude: ca.SX, tau: ca.SX) -> ca.SX:
    """A step of magnitude at onset through a first-order lag tau (exact solution); tau = 0 is the bare step."""
    lag = magnitude * (1 - ca.exp(-(t - onset) / ca.fmax(tau, 1e-300)))
    return ca.if_else(t < onset, 0, ca.if_else(tau > 0, lag, magnitude))


def reference_function(name: str, position) -> ca.Function:
    """t -> [position; velocity; acceleration] (9) of one trajectory."""
    t = ca.SX.sym("t")
    p = ca.vertcat(*position(t))
    v = ca.jacobian(p, t)
    a = ca.jacobian(v, t)
    return ca.Function(name, [t], [ca.cse(ca.vertcat(p, v, a))], ["t"], ["ref"])


def functions() -> list[ca.Function]:
    """The generated C's functions: the three trajectories and the gust."""
    t, onset, mag, tau = (ca.SX.sym(n) for n in ("t", "onset", "magnitude", "tau"))
    g = ca.Function("tl_gust", [t, onset, mag, tau], [gust(t, onset, mag, tau)], ["t", "onset", "magnitude", "tau"], ["d"])
    return [reference_function("tl_trajectory_1", circle), reference_function("tl_trajectory_2", table_5_3),
            reference_function("tl_trajectory_3", appendix_a), g]

"""Unit dual quaternions for the formation of Appendix B, as CasADi expressions (so the formation
controller's C is generated from them, with exact Jacobians by automatic differentiation).

A quaternion is a 4-vector [h1 h2 h3 h4] = h1 + h2 i + h3 j + h4 k (vec4); a dual quaternion an
8-vector [P; D] = P + eps D (vec8). Everything here works on casadi SX/MX/DM column vectors.
dqrobotics (numeric, C++) is the independent reference the tests hold this module to; it cannot be
compiled into an FMU, hence this small module.
"""

from __future__ import annotations

import casadi as ca

E4 = ca.DM([1, -1, -1, -1])
E8 = ca.vertcat(E4, E4)


def hplus4(h):
    """H4+(h): vec4(h a) = hplus4(h) vec4(a)."""
    a, b, c, d = h[0], h[1], h[2], h[3]
    return ca.vertcat(ca.horzcat(a, -b, -c, -d), ca.horzcat(b, a, -d, c), ca.horzcat(c, d, a, -b), ca.horzcat(d, -c, b, a))


def hminus4(h):
    """H4-(h): vec4(a h) = hminus4(h) vec4(a)."""
    a, b, c, d = h[0], h[1], h[2], h[3]
    return ca.vertcat(ca.horzcat(a, -b, -c, -d), ca.horzcat(b, a, d, -c), ca.horzcat(c, -d, a, b), ca.horzcat(d, c, -b, a))


def hplus8(x):
    """H8+(x): vec8(x y) = hplus8(x) vec8(y)."""
    p, d = hplus4(x[0:4]), hplus4(x[4:8])
    return ca.vertcat(ca.horzcat(p, ca.SX.zeros(4, 4) if isinstance(p, ca.SX) else ca.DM.zeros(4, 4)), ca.horzcat(d, p))


def hminus8(x):
    """H8-(x): vec8(y x) = hminus8(x) vec8(y)."""
    p, d = hminus4(x[0:4]), hminus4(x[4:8])
    return ca.vertcat(ca.horzcat(p, ca.SX.zeros(4, 4) if isinstance(p, ca.SX) else ca.DM.zeros(4, 4)), ca.horzcat(d, p))


def qmul(a, b):
    return ca.mtimes(hplus4(a), b)


def mul(x, y):
    """Dual quaternion product: (Px + eps Dx)(Py + eps Dy) = Px Py + eps (Px Dy + Dx Py)."""
    return ca.vertcat(qmul(x[0:4], y[0:4]), qmul(x[0:4], y[4:8]) + qmul(x[4:8], y[0:4]))


def conj(x):
    """x* = Re(x) - Im(x) on both parts; for a unit dual quaternion, its inverse."""
    return x * E8


def pose(position, yaw):
    """The UAV's transformation x = r + eps (1/2) p r with r = cos(psi/2) + k sin(psi/2) (Sec. B.2.2)."""
    r = ca.vertcat(ca.cos(yaw / 2), 0, 0, ca.sin(yaw / 2))
    p = ca.vertcat(0, position[0], position[1], position[2])
    return ca.vertcat(r, 0.5 * qmul(p, r))


def translation(x):
    """p (as a 3-vector) of x = r + eps (1/2) p r: p = 2 D(x) P(x)*."""
    p = 2 * qmul(x[4:8], x[0:4] * E4)
    return p[1:4]


def power(x, exponent: float):
    """x^exponent of a unit dual quaternion, exp(exponent log x): rotate by exponent times the angle about the same
    axis, translate by exponent times the translation (the phi-th part of Adorno et al. (2010) is power(x, 1/phi)).

    Near theta = 0 (the formation's rotations are small or none) cos(a theta/2) and sin(a theta/2)/sin(theta/2) are
    written as series in s2 = sin^2(theta/2) = |Im r|^2, both even in sin(theta/2): the expression and its exact
    derivatives (the Jacobians of Sec. B.1) stay finite there, where acos or a norm would not."""
    a = exponent
    r = x[0:4]
    s2 = ca.sumsqr(r[1:4])
    small = s2 < 1e-8
    safe_s2 = ca.if_else(small, 1.0, s2)
    half = ca.atan2(ca.sqrt(safe_s2), r[0])  # theta / 2 (the exact branch only)
    cos_series = 1 - a**2 / 2 * s2 + (a**4 / 24 - a**2 / 6) * s2 * s2
    ratio_series = a + (a - a**3) / 6 * s2 + (3 * a / 40 - a**3 / 12 + a**5 / 120) * s2 * s2
    cos_a = ca.if_else(small, cos_series, ca.cos(a * half))
    ratio = ca.if_else(small, ratio_series, ca.sin(a * half) / ca.sqrt(safe_s2))
    r_a = ca.vertcat(cos_a, ratio * r[1:4])
    p = 2 * qmul(x[4:8], r * E4)  # the translation quaternion
    return ca.vertcat(r_a, 0.5 * qmul(a * p, r_a))

"""Parametric reference trajectories beside the thesis's: figure-eight (lemniscate), lissajous, step and ramp.

Each is a CasADi position expression in t and one parameter vector (SHAPE_PARAMETERS, the scenario
FMU's `shape_*` parameters); velocity and acceleration are its exact time derivatives, as for the
thesis's trajectories (trajectories.py), and the FMU runs the C that CasADi generates. psi_ref = 0.

With theta = 2 pi t / period and c, S the centre and size vectors:
- lemniscate (Bernoulli's, stretched so that size_y is its half-height):
  x = c_x + S_x cos(theta)/(1 + sin^2 theta), y = c_y + 2 sqrt(2) S_y sin(theta) cos(theta)/(1 + sin^2 theta),
  z = c_z + S_z sin(theta)
- lissajous: x_i = c_i + S_i sin(ratio_i theta + phase_i)
- step: c until onset, then c + S; with rise > 0 the quintic smoothstep 10 s^3 - 15 s^4 + 6 s^5 over
  [onset, onset + rise] (position, velocity and acceleration continuous); rise = 0 is the bare step
- ramp: c until onset, then c + S (t - onset)/period until onset + period, then c + S (velocity steps)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import casadi as ca


@dataclass(frozen=True)
class ShapeParameter:
    name: str  # the FMU parameter is shape_<name>
    default: float
    unit: str
    description: str


SHAPE_PARAMETERS = (
    *(ShapeParameter(f"center_{a}", d, "m", f"{a} of the shape's centre (step, ramp: the start)") for a, d in zip("xyz", (0.0, 0.0, 3.0))),
    *(ShapeParameter(f"size_{a}", d, "m", f"{a} half-extent (lemniscate, lissajous), step or ramp length")
      for a, d in zip("xyz", (2.0, 1.0, 0.0))),
    ShapeParameter("period", 20.0, "s", "one loop (lemniscate, lissajous: of theta); the ramp's duration"),
    ShapeParameter("onset", 5.0, "s", "when the step or ramp starts"),
    ShapeParameter("rise", 0.0, "s", "the step's smooth transition (0: a bare step)"),
    *(ShapeParameter(f"ratio_{a}", d, "1", f"lissajous: frequency of {a} in multiples of 1/period")
      for a, d in zip("xyz", (3.0, 2.0, 1.0))),
    *(ShapeParameter(f"phase_{a}", d, "rad", f"lissajous: phase of {a}") for a, d in zip("xyz", (math.pi / 2, 0.0, 0.0))),
    ShapeParameter("duration", 40.0, "s", "the run's length for this trajectory"),
)
SHAPE_NAMES = tuple(p.name for p in SHAPE_PARAMETERS)
# trajectory codes of the scenario FMU (0-3 are the thesis's, 4 the waypoints)
SHAPES = {5: "lemniscate", 6: "lissajous", 7: "step", 8: "ramp"}


def _split(s):
    i = {n: k for k, n in enumerate(SHAPE_NAMES)}
    vec = lambda stem: [s[i[f"{stem}_{a}"]] for a in "xyz"]  # noqa: E731
    return vec("center"), vec("size"), s[i["period"]], s[i["onset"]], s[i["rise"]], vec("ratio"), vec("phase")


def lemniscate(t, s) -> list:
    c, S, period, *_ = _split(s)
    th = 2 * math.pi * t / period
    den = 1 + ca.sin(th) ** 2
    return [c[0] + S[0] * ca.cos(th) / den, c[1] + 2 * math.sqrt(2) * S[1] * ca.sin(th) * ca.cos(th) / den,
            c[2] + S[2] * ca.sin(th)]


def lissajous(t, s) -> list:
    c, S, period, _, _, ratio, phase = _split(s)
    th = 2 * math.pi * t / period
    return [c[k] + S[k] * ca.sin(ratio[k] * th + phase[k]) for k in range(3)]


def step(t, s) -> list:
    c, S, _, onset, rise, *_ = _split(s)
    u = (t - onset) / ca.fmax(rise, 1e-9)  # the bare step never reads u: no overflow
    smooth = ca.if_else(u < 1, u**3 * (10 - 15 * u + 6 * u**2), 1)
    fraction = ca.if_else(t < onset, 0, ca.if_else(rise > 0, smooth, 1))
    return [c[k] + S[k] * fraction for k in range(3)]


def ramp(t, s) -> list:
    c, S, period, onset, *_ = _split(s)
    fraction = ca.if_else(t < onset, 0, ca.if_else(t < onset + period, (t - onset) / period, 1))
    return [c[k] + S[k] * fraction for k in range(3)]


POSITIONS = {"lemniscate": lemniscate, "lissajous": lissajous, "step": step, "ramp": ramp}


def shape_function(name: str) -> ca.Function:
    """(t, shape parameters) -> [position; velocity; acceleration] (9) of one shape, named tl_shape_<name>."""
    t, s = ca.SX.sym("t"), ca.SX.sym("s", len(SHAPE_PARAMETERS))
    p = ca.vertcat(*POSITIONS[name](t, s))
    v = ca.jacobian(p, t)
    a = ca.jacobian(v, t)
    return ca.Function(f"tl_shape_{name}", [t, s], [ca.cse(ca.vertcat(p, v, a))], ["t", "s"], ["ref"])


def functions() -> list[ca.Function]:
    return [shape_function(SHAPES[k]) for k in sorted(SHAPES)]

"""The scenario FMU's reference evaluated in Python from the FMU's own parameters (the twin of its C).

The thesis's trajectories and the shapes call the same CasADi functions the FMU's C is generated from; the
waypoints evaluate the same quintics (waypoints.MinimumJerk). The feasibility check reads the reference here,
and the tests check the FMU against it.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

import numpy as np

from . import knot_file, shapes, trajectories

WAYPOINTS = 4  # the scenario FMU's trajectory code of a waypoint file


@dataclass(frozen=True)
class Samples:
    """The reference at some times: load position, velocity, acceleration (m, 3) and yaw, yaw rate (m,)."""

    t: np.ndarray
    p: np.ndarray
    v: np.ndarray
    a: np.ndarray
    psi: np.ndarray
    psi_dot: np.ndarray


@cache
def _casadi(code: int):
    if code in shapes.SHAPES:
        return shapes.shape_function(shapes.SHAPES[code])
    return trajectories.functions()[code - 1]


def shape_vector(parameters: dict) -> np.ndarray:
    """The shape_* parameters in the order of shapes.SHAPE_PARAMETERS (defaults where not given)."""
    return np.array([float(parameters.get(f"shape_{p.name}", p.default)) for p in shapes.SHAPE_PARAMETERS])


def evaluate(parameters: dict, times) -> Samples:
    """The reference the scenario FMU with these parameters outputs at the times (doStep(t) samples at t)."""
    t = np.atleast_1d(np.asarray(times, dtype=float))
    code = int(parameters.get("trajectory", 1))
    zeros = np.zeros(t.size)
    if code == 0:
        z3 = np.zeros((t.size, 3))
        return Samples(t, z3, z3, z3, zeros, zeros)
    if code == WAYPOINTS:
        pos, vel, acc = knot_file.from_parameters(parameters).evaluate(t)
        return Samples(t, pos[:, :3], vel[:, :3], acc[:, :3], pos[:, 3], vel[:, 3])
    f = _casadi(code)
    args = [t[None, :]] + ([np.repeat(shape_vector(parameters)[:, None], t.size, axis=1)] if code in shapes.SHAPES else [])
    ref = np.array(f.map(t.size)(*args)).T  # (m, 9)
    return Samples(t, ref[:, 0:3], ref[:, 3:6], ref[:, 6:9], zeros, zeros)


def duration(parameters: dict) -> float:
    """The duration output of the scenario FMU with these parameters (hover: 40 s, as the FMU says)."""
    code = int(parameters.get("trajectory", 1))
    if code == WAYPOINTS:
        return knot_file.from_parameters(parameters).duration
    if code in shapes.SHAPES:
        return float(parameters.get("shape_duration", shape_vector({})[shapes.SHAPE_NAMES.index("duration")]))
    return trajectories.DURATION.get(code, 40.0)

"""Physical parameters of the tilt-rotor UAV with suspended load (thesis Table 5.1, 5.2).

Every value is a named, typed parameter with its unit, so that the model, the FMU's
parameter list and the documentation all come from this one table.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np


@dataclass(frozen=True)
class ParameterSpec:
    """One scalar model parameter: FMU name, default, unit and meaning."""

    name: str
    default: float
    unit: str
    description: str
    kind: str = "real"  # "real" or "integer"


def _vector(prefix: str, values, unit: str, what: str) -> list[ParameterSpec]:
    return [
        ParameterSpec(f"{prefix}_{axis}", float(v), unit, f"{what}, {axis} component")
        for axis, v in zip("xyz", values)
    ]


def _inertia(prefix: str, xx, yy, zz, xy, xz, yz, what: str) -> list[ParameterSpec]:
    entries = {"xx": xx, "yy": yy, "zz": zz, "xy": xy, "xz": xz, "yz": yz}
    return [
        ParameterSpec(f"{prefix}_{k}", float(v) * 1e-6, "kg.m2", f"{what}, {k} entry (in its body frame)")
        for k, v in entries.items()
    ]


# Order matters: it is the layout of the parameter vector p fed to the compiled model.
MODEL_PARAMETERS: tuple[ParameterSpec, ...] = tuple(
    [
        ParameterSpec("m_L", 0.05, "kg", "load mass"),
        ParameterSpec("m_1", 1.70249, "kg", "UAV main body mass (C1)"),
        ParameterSpec("m_2", 0.13973, "kg", "right thruster group mass (C2)"),
        ParameterSpec("m_3", 0.13973, "kg", "left thruster group mass (C3)"),
        ParameterSpec("l", 0.5, "m", "rod length, load centre to UAV geometric centre"),
    ]
    + _vector("d_C1", [-0.00433, 0.00060, -0.04559], "m", "displacement B -> C1 in B")
    + _vector("d_C2", [0.00002, -0.27761, 0.05493], "m", "displacement B -> C2 in B")
    + _vector("d_C3", [0.00077, 0.27761, 0.05493], "m", "displacement B -> C3 in B")
    + _inertia("I_L", 2.645, 2.645, 2.645, 0.0, 0.0, 0.0, "load inertia")
    + _inertia("I_1", 3697.66749, 840.10403, 3865.05354, 0.36342, -9.51029, 0.61804, "main body inertia")
    + _inertia("I_2", 441.68245, 441.67985, 0.64418, 0.0, 0.0, -1.07006, "right thruster inertia")
    + _inertia("I_3", 441.68245, 441.67985, 0.64418, 0.0, 0.0, 1.07006, "left thruster inertia")
    + [
        ParameterSpec("g", 9.81, "m/s2", "gravitational acceleration"),
        ParameterSpec("k_tau", 1.7e-7, "N.m.s2", "propeller drag coefficient"),
        ParameterSpec("b", 9.5e-6, "N.s2", "propeller thrust coefficient"),
        ParameterSpec("lambda_R", 1.0, "1", "right propeller spin sign (+1 counter-clockwise)", "integer"),
        ParameterSpec("lambda_L", -1.0, "1", "left propeller spin sign (-1 clockwise)", "integer"),
        ParameterSpec("beta", math.radians(5.0), "rad", "fixed inward inclination of the thrusters (5 deg)"),
        ParameterSpec("mu_gamma", 0.005, "N.m.s/rad", "viscous friction at the rod-UAV joint"),
    ]
)

# Actuator saturation (Table 5.2): applied by the plant to its inputs.
ACTUATOR_LIMITS: tuple[ParameterSpec, ...] = (
    ParameterSpec("f_min", 0.0, "N", "minimum thrust of each propeller"),
    ParameterSpec("f_max", 30.0, "N", "maximum thrust of each propeller"),
    ParameterSpec("tau_max", 2.0, "N.m", "servo torque magnitude limit"),
)

ACTUATOR_LIMIT = {s.name: s.default for s in ACTUATOR_LIMITS}  # by name: f_min, f_max, tau_max

PARAMETER_NAMES: tuple[str, ...] = tuple(s.name for s in MODEL_PARAMETERS)
N_PARAMETERS = len(MODEL_PARAMETERS)
_INDEX = {name: i for i, name in enumerate(PARAMETER_NAMES)}



class ParameterError(ValueError):
    """A parameter set that does not describe a physical plant."""


def index(name: str) -> int:
    """Position of a named parameter in the parameter vector."""
    return _INDEX[name]


def default_vector() -> np.ndarray:
    """The Table 5.1 parameters as the vector the compiled model takes."""
    return np.array([s.default for s in MODEL_PARAMETERS], dtype=float)


def vector_from(overrides: dict[str, float] | None = None) -> np.ndarray:
    """Table 5.1 defaults with some entries replaced by name (unknown names are an error)."""
    p = default_vector()
    for name, value in (overrides or {}).items():
        if name not in _INDEX:
            raise ParameterError(f"unknown plant parameter '{name}'")
        p[_INDEX[name]] = float(value)
    return p


def inertia_matrix(p: np.ndarray, prefix: str) -> np.ndarray:
    """Symmetric 3x3 inertia tensor named prefix (I_L, I_1, I_2, I_3) from a parameter vector."""
    g = lambda k: p[_INDEX[f"{prefix}_{k}"]]  # noqa: E731
    return np.array(
        [[g("xx"), g("xy"), g("xz")], [g("xy"), g("yy"), g("yz")], [g("xz"), g("yz"), g("zz")]]
    )


_PREFIXES = ("I_L", "I_1", "I_2", "I_3")
_INERTIA = np.array([_INDEX[f"{prefix}_{k}"] for prefix in _PREFIXES for k in ("xx", "xy", "xz", "yy", "yz", "zz")])


@lru_cache(maxsize=64)
def _inertia_problem(entries: bytes) -> str | None:
    """What is wrong with the four inertia tensors of these entries (p[_INERTIA]'s bytes), or None; worked out once per
    set of tensors: a search over the load's mass or the rod checks the same tensors at every point."""
    p = np.zeros(N_PARAMETERS)
    p[_INERTIA] = np.frombuffer(entries)
    eigs = np.linalg.eigvalsh(np.stack([inertia_matrix(p, prefix) for prefix in _PREFIXES]))  # one call for the four
    for prefix, eig in zip(_PREFIXES, eigs):
        if eig[0] <= 0.0:
            return f"inertia {prefix} must be positive definite (smallest eigenvalue {eig[0]:.3g})"
        if eig[0] + eig[1] < eig[2] * (1 - 1e-9):
            return f"inertia {prefix} violates the triangle inequality of principal moments"
    return None


def validate(p: np.ndarray, limits: dict[str, float] | None = None) -> None:
    """Raise ParameterError with a one-line reason if p is not a physical plant."""
    p = np.asarray(p, dtype=float)
    if p.shape != (N_PARAMETERS,):
        raise ParameterError(f"expected {N_PARAMETERS} plant parameters, got shape {p.shape}")
    bad = [PARAMETER_NAMES[i] for i in np.flatnonzero(~np.isfinite(p))]
    if bad:
        raise ParameterError(f"non-finite plant parameter(s): {', '.join(bad)}")
    for name in ("m_L", "m_1", "m_2", "m_3", "l", "b"):
        if p[_INDEX[name]] <= 0.0:
            raise ParameterError(f"parameter {name} must be positive, got {p[_INDEX[name]]:g}")
    for name in ("g", "k_tau", "mu_gamma"):
        if p[_INDEX[name]] < 0.0:
            raise ParameterError(f"parameter {name} must be non-negative, got {p[_INDEX[name]]:g}")
    for name in ("lambda_R", "lambda_L"):
        if p[_INDEX[name]] not in (-1.0, 1.0):
            raise ParameterError(f"parameter {name} must be +1 or -1, got {p[_INDEX[name]]:g}")
    if not abs(p[_INDEX["beta"]]) < math.pi / 2:
        raise ParameterError(f"parameter beta must lie in (-pi/2, pi/2) rad, got {p[_INDEX['beta']]:g}")
    problem = _inertia_problem(p[_INERTIA].tobytes())
    if problem:
        raise ParameterError(problem)
    if limits:
        lo, hi, tau = limits["f_min"], limits["f_max"], limits["tau_max"]
        if not (np.isfinite([lo, hi, tau]).all() and 0.0 <= lo < hi and tau > 0.0):
            raise ParameterError(
                f"actuator limits need 0 <= f_min < f_max and tau_max > 0, got f_min={lo:g}, f_max={hi:g}, tau_max={tau:g}"
            )

"""Wind beyond the thesis's gusts: steady wind, Dryden turbulence (MIL-F-8785C, low altitude) and a user's
wind profile, all wind velocities; the scenario FMU turns their sum into a drag force on the load.

Dryden (MIL-F-8785C 3.7.2.1, the form of MIL-HDBK-1797 with its scale lengths doubled): with h the altitude in
ft (10 ft <= h <= 1000 ft, the low-altitude model), W20 the wind speed at 20 ft of the severity (light 15,
moderate 30, severe 45 knots), V the speed at which the frozen field passes the vehicle:

    sigma_w = 0.1 W20,  sigma_u = sigma_v = sigma_w / (0.177 + 0.000823 h)^0.4
    L_w = h,            L_u = L_v = h / (0.177 + 0.000823 h)^1.2                      (ft)
    H_u(s) = sigma_u sqrt(2 L_u / (pi V)) / (1 + (L_u/V) s)
    H_v(s) = sigma_v sqrt(L_v / (pi V)) (1 + sqrt(3) (L_v/V) s) / (1 + (L_v/V) s)^2    (H_w likewise)

driven by white noise of unit one-sided spectral density (so var = sigma^2). The scenario FMU discretizes the
filters exactly for its step h (scenario_model.c): x_{k+1} = e^{Ah} x_k + w_k, w_k ~ N(0, Q_d(h)),
Q_d = integral_0^h e^{As} B B' e^{A's} ds, started in the stationary distribution, so the samples have the
model's covariance at any step. Correlations (xi = V tau): R_u = sigma_u^2 e^{-xi/L_u},
R_v = sigma_v^2 (1 - xi/(2 L_v)) e^{-xi/L_v}. This module holds the same formulas for the tests and the docs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .files import Reader, ScenarioFileError, read_rows, read_structured
from .waypoints import MAX_TIME

FT = 0.3048  # m
KNOT = 0.514444  # m/s
SEVERITIES = {"light": 1, "moderate": 2, "severe": 3}
W20 = {1: 15 * KNOT, 2: 30 * KNOT, 3: 45 * KNOT}  # m/s, MIL-F-8785C low-altitude intensities
ALTITUDE_RANGE = (10 * FT, 1000 * FT)  # the low-altitude model's validity
MAX_PROFILE = 64  # rows of a wind profile the scenario FMU carries
PROFILE_FIELDS = ("t", "x", "y", "z")
MAX_WIND = 100.0  # m/s, any component: three times hurricane force (33 m/s); beyond it the drag model means nothing
MAX_AIRSPEED = 1000.0  # m/s
MAX_DRAG_AREA = 100.0  # m2
PROFILE_RANGES = {"t": (0.0, MAX_TIME), **{f: (-MAX_WIND, MAX_WIND) for f in "xyz"}}


@dataclass(frozen=True)
class Dryden:
    """Intensities (m/s), scale lengths (m) and the passing speed V (m/s) of the three components."""

    sigma: tuple[float, float, float]
    length: tuple[float, float, float]
    airspeed: float

    @property
    def time_constants(self) -> tuple[float, float, float]:
        return tuple(L / self.airspeed for L in self.length)

    def correlation(self, tau) -> np.ndarray:
        """The model's autocorrelations R_u, R_v, R_w at the lags tau (s), shape (3, len(tau))."""
        tau = np.abs(np.asarray(tau, dtype=float))
        (su, sv, sw), (Lu, Lv, Lw), V = self.sigma, self.length, self.airspeed
        xi = V * tau
        return np.array([su**2 * np.exp(-xi / Lu), sv**2 * (1 - xi / (2 * Lv)) * np.exp(-xi / Lv),
                         sw**2 * (1 - xi / (2 * Lw)) * np.exp(-xi / Lw)])


def dryden(severity: int, altitude: float, airspeed: float = 0.0, steady=(0.0, 0.0, 0.0)) -> Dryden:
    """MIL-F-8785C low altitude. airspeed 0: the steady wind's speed, or W20 without steady wind (scenario_model.c)."""
    h = altitude / FT
    sw = 0.1 * W20[severity]
    su = sw / (0.177 + 0.000823 * h) ** 0.4
    Lu = h / (0.177 + 0.000823 * h) ** 1.2 * FT
    speed = math.hypot(*steady)
    V = airspeed if airspeed > 0 else (speed if speed > 0 else W20[severity])
    return Dryden((su, su, sw), (Lu, Lu, altitude), V)


def correlation_time(component: int) -> float:
    """The lag, in units of L/V, at which the model's normalized autocorrelation falls to 1/e: 1 for u, and the
    root of (1 - x/2) e^{-x} = e^{-1} for v and w."""
    if component == 0:
        return 1.0
    from scipy.optimize import brentq

    return brentq(lambda x: (1 - x / 2) * math.exp(-x) - math.exp(-1), 0.1, 1.0)


WIND_SCHEMA = {
    "type": "object", "additionalProperties": False,
    "properties": {
        "steady": {"type": "array", "items": {"type": "number", "minimum": -MAX_WIND, "maximum": MAX_WIND}, "minItems": 3, "maxItems": 3},
        "dryden": {"type": "object", "additionalProperties": False, "required": ["severity"], "properties": {
            "severity": {"enum": list(SEVERITIES)},
            "altitude": {"type": "number", "minimum": ALTITUDE_RANGE[0], "maximum": ALTITUDE_RANGE[1]},
            "airspeed": {"type": "number", "minimum": 0, "maximum": MAX_AIRSPEED}}},
        "profile": {"type": "array", "items": {"type": "object", "additionalProperties": False, "required": list(PROFILE_FIELDS),
                                               "properties": {f: {"type": "number", "minimum": PROFILE_RANGES[f][0],
                                                                  "maximum": PROFILE_RANGES[f][1]} for f in PROFILE_FIELDS}}},
        "drag_area": {"type": "number", "minimum": 0, "maximum": MAX_DRAG_AREA},
        "gusts": {"type": "boolean"},
    },
}


def _profile_parameters(rows: list[dict], where: list[str], source: str) -> dict:
    if len(rows) > MAX_PROFILE:
        raise ScenarioFileError(f"{source}: at most {MAX_PROFILE} wind profile rows fit the scenario FMU, got {len(rows)}")
    if not rows:
        raise ScenarioFileError(f"{source}: the wind profile has no rows")
    out: dict = {"wind_profile_count": len(rows)}
    for i, (row, at) in enumerate(zip(rows, where)):
        for f in PROFILE_FIELDS:
            if not math.isfinite(row[f]):
                raise ScenarioFileError(f"{source}: {at}: {f} is {row[f]}, not a finite number")
            low, high = PROFILE_RANGES[f]
            if not low <= row[f] <= high:
                raise ScenarioFileError(f"{source}: {at}: {f} = {row[f]:.6g} is outside {low:g} to {high:g} {'s' if f == 't' else 'm/s'}")
        if i and not row["t"] > rows[i - 1]["t"]:
            raise ScenarioFileError(f"{source}: {at}: t = {row['t']:g} s is not after the previous row's t = {rows[i - 1]['t']:g} s")
        for f in PROFILE_FIELDS:
            out[f"wind_profile_{f}_{i}"] = float(row[f])
    return out


def read_wind(path: Path, read: Reader) -> dict:
    """The scenario FMU's wind parameters from a wind file: YAML/JSON (steady, dryden, profile, drag_area, gusts) or
    a CSV profile with the header t,x,y,z (wind velocity in m/s, linear between rows, held outside)."""
    import jsonschema

    path = Path(path)
    source = str(path)
    if path.suffix.lower() == ".csv":
        rows, where = read_rows(path, PROFILE_FIELDS, PROFILE_FIELDS, read)
        return _profile_parameters(rows, where, source)
    data = read_structured(path, read)
    errors = sorted(jsonschema.Draft202012Validator(WIND_SCHEMA).iter_errors(data), key=lambda e: list(e.path))
    if errors:
        where = ".".join(str(p) for p in errors[0].absolute_path) or "(top level)"
        raise ScenarioFileError(f"{source}: {where}: {errors[0].message[:200]}")
    out: dict = {}
    for k, v in enumerate(data.get("steady", ())):
        if not math.isfinite(v):
            raise ScenarioFileError(f"{source}: steady.{k}: {v} is not a finite number")
        out[f"steady_wind_{'xyz'[k]}"] = float(v)
    if "dryden" in data:
        d = data["dryden"]
        out["dryden"] = SEVERITIES[d["severity"]]
        if "altitude" in d:
            out["dryden_altitude"] = float(d["altitude"])
        if "airspeed" in d:
            out["dryden_airspeed"] = float(d["airspeed"])
    if "profile" in data:
        rows = data["profile"]
        out.update(_profile_parameters(rows, [f"profile.{i}" for i in range(len(rows))], source))
    if "drag_area" in data:
        out["drag_area"] = float(data["drag_area"])
    if "gusts" in data:
        out["gusts"] = bool(data["gusts"])
    return out

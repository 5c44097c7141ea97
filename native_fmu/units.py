"""SI base-unit exponents of the unit strings the FMUs use ("N.m", "kg.m2/s", "m/s2", ...).

A unit string is factors joined by '.' with an optional '/' before the denominator; a factor is
a symbol with an optional integer power ("m2"). "1" is dimensionless.
"""

from __future__ import annotations

import re
from collections import Counter

BASE = ("kg", "m", "s", "A", "K", "mol", "cd", "rad")
# derived symbols in base units
_DERIVED = {"N": {"kg": 1, "m": 1, "s": -2}, "J": {"kg": 1, "m": 2, "s": -2}, "W": {"kg": 1, "m": 2, "s": -3},
            "Hz": {"s": -1}}
_FACTOR = re.compile(r"([A-Za-z]+)(-?\d+)?\Z")


class UnitError(ValueError):
    """A unit string this module cannot reduce to SI base units."""


def _factors(text: str, sign: int, into: Counter) -> None:
    for factor in filter(None, text.split(".")):
        match = _FACTOR.match(factor)
        if not match:
            raise UnitError(f"cannot read unit factor {factor!r}")
        symbol, power = match.group(1), int(match.group(2) or 1)
        base = {symbol: 1} if symbol in BASE else _DERIVED.get(symbol)
        if base is None:
            raise UnitError(f"unknown unit symbol {symbol!r}")
        for b, e in base.items():
            into[b] += sign * power * e


def base_exponents(unit: str) -> dict[str, int]:
    """{'kg': 1, 'm': 2, 's': -2} for 'N.m'; {} for '1'."""
    if unit == "1":
        return {}
    num, _, den = unit.partition("/")
    total: Counter = Counter()
    _factors(num, 1, total)
    _factors(den, -1, total)
    return {b: total[b] for b in BASE if total[b]}


# Display units the FMI 3.0 descriptions declare (name, factor from the unit): angles read in degrees.
DISPLAY_UNITS = {"rad": (("deg", 57.29577951308232),), "rad/s": (("deg/s", 57.29577951308232),),
                 "rad/s2": (("deg/s2", 57.29577951308232),)}


def display_units(unit: str) -> tuple[tuple[str, float], ...]:
    """The display units of a unit, the first one the variables show by default (none for most units)."""
    return DISPLAY_UNITS.get(unit, ())

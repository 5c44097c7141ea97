"""The type checks of the request objects' fields: a wrong type is a TypeError naming the object and the field, as a
Python function's is; the values themselves are checked by the core's field types (case/fields.py), as the command's parser checks them."""

from __future__ import annotations

import difflib
import functools
import math
import numbers
from collections.abc import Mapping
from pathlib import Path

NUMBER = "a number"


def closest_field(cls):
    """A request class whose misspelt keyword names the field it is closest to (docs/api.md): the TypeError of
    ``Case(stop_tme=3)`` says "did you mean 'stop_time'?"."""
    init = cls.__init__

    @functools.wraps(init)
    def checked_init(self, *args, **kwargs):
        from dataclasses import fields

        names = [f.name for f in fields(cls) if f.init]
        for key in kwargs:
            if key not in names:
                close = difflib.get_close_matches(key, names, n=1)
                raise TypeError(f"{cls.__name__}() got an unexpected keyword argument {key!r}"
                                + (f" (did you mean {close[0]!r}?)" if close else f"; its fields are {', '.join(names)}"))
        init(self, *args, **kwargs)

    cls.__init__ = checked_init
    return cls


def _is_bool(value: object) -> bool:
    import numpy as np

    return isinstance(value, (bool, np.bool_))  # numpy's bool is a truth value, no number, here too


def as_number(value: object) -> float | int | None:
    """An int, float or numpy scalar as a plain Python number (an integer stays an int); None for anything else. An
    integer beyond a double's range becomes an infinity, which every value check refuses in the command's words."""
    if _is_bool(value):
        return None
    if isinstance(value, numbers.Integral):  # beyond a 64-bit integer no FMI type holds it: as a double, infinite
        return int(value) if abs(int(value)) < 2**63 else math.inf if value > 0 else -math.inf
    if isinstance(value, numbers.Real):
        try:
            return float(value)
        except OverflowError:
            return math.inf if value > 0 else -math.inf
    return None


def _refuse(owner: str, name: str, what: str, value: object) -> TypeError:
    return TypeError(f"{owner}.{name} must be {what}, got {type(value).__name__} {value!r:.80}")


def flag(owner: str, name: str, value: object) -> bool:
    if not isinstance(value, bool):
        raise _refuse(owner, name, "True or False", value)
    return value


def whole(owner: str, name: str, value: object, optional: bool = True) -> int | None:
    if value is None and optional:
        return None
    if _is_bool(value) or not isinstance(value, numbers.Integral):
        raise _refuse(owner, name, "a whole number (int)" + " or None" * optional, value)
    return int(value)


def number(owner: str, name: str, value: object, optional: bool = True) -> float | int | None:
    if value is None and optional:
        return None
    number = as_number(value)  # an int stays an int: the value's check says it as the command line would ("got -1")
    if number is None:
        raise _refuse(owner, name, NUMBER + " or None" * optional, value)
    return number


def text(owner: str, name: str, value: object, optional: bool = True) -> str | None:
    if value is None and optional:
        return None
    if not isinstance(value, str):
        raise _refuse(owner, name, "a str" + " or None" * optional, value)
    return value


def path(owner: str, name: str, value: object, optional: bool = True) -> Path | None:
    if value is None and optional:
        return None
    if not isinstance(value, (str, Path)) or value == "":
        raise _refuse(owner, name, "a path (str or pathlib.Path)" + " or None" * optional, value)
    return Path(value)


def pairs(owner: str, name: str, value: object, values: tuple[type, ...], what: str) -> tuple[tuple[str, object], ...]:
    """A mapping {key: value}, or pairs (key, value), in order; each value of the types given (bool counts apart)."""
    if isinstance(value, Mapping):
        items = list(value.items())
    elif isinstance(value, (list, tuple)) and all(isinstance(p, (list, tuple)) and len(p) == 2 for p in value):
        items = [tuple(p) for p in value]
    else:
        raise _refuse(owner, name, f"a mapping {{key: {what}}}", value)
    out = []
    for key, item in items:
        if not isinstance(key, str):
            raise _refuse(owner, f"{name} key", "a str", key)
        if _is_bool(item):
            item = bool(item)
        elif not isinstance(item, str) and as_number(item) is not None:
            item = as_number(item)  # a numpy scalar is a number (numbers.Real)
        if not isinstance(item, values):
            raise _refuse(owner, f"{name}[{key!r}]", what, item)
        out.append((key, item))
    return tuple(out)

"""The type checks of the request objects' fields: a wrong type is a TypeError naming the object and the field, as a
Python function's is; the values themselves are the command's to check (arguments.checked)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

NUMBER = "a number"


def _refuse(owner: str, name: str, what: str, value: object) -> TypeError:
    return TypeError(f"{owner}.{name} must be {what}, got {type(value).__name__} {value!r:.80}")


def flag(owner: str, name: str, value: object) -> bool:
    if not isinstance(value, bool):
        raise _refuse(owner, name, "True or False", value)
    return value


def whole(owner: str, name: str, value: object, optional: bool = True) -> int | None:
    if value is None and optional:
        return None
    if isinstance(value, bool) or not isinstance(value, int):
        raise _refuse(owner, name, "a whole number (int)" + " or None" * optional, value)
    return value


def number(owner: str, name: str, value: object, optional: bool = True) -> float | None:
    if value is None and optional:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise _refuse(owner, name, NUMBER + " or None" * optional, value)
    return float(value)


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
    for key, item in items:
        if not isinstance(key, str):
            raise _refuse(owner, f"{name} key", "a str", key)
        if not isinstance(item, values):
            raise _refuse(owner, f"{name}[{key!r}]", what, item)
    return tuple(items)

"""The --set values checked against the FMUs' own types before anything is loaded: text for a Real is the user's to fix
(one line), not a failure deep in the FMI call."""

from __future__ import annotations

from ..user_error import UserError

_NUMBERS = ("Real", "Float32", "Float64", "Integer", "Int8", "UInt8", "Int16", "UInt16", "Int32", "UInt32", "Int64", "UInt64",
            "Enumeration")
_WHOLE = _NUMBERS[3:]


def _fits(kind: str, value: object) -> bool:
    if kind == "String":
        return isinstance(value, str)
    if kind == "Boolean":
        return isinstance(value, bool) or (isinstance(value, int) and value in (0, 1))
    if kind in _WHOLE:
        return isinstance(value, int) and not isinstance(value, bool)
    return kind not in _NUMBERS or (isinstance(value, (int, float)) and not isinstance(value, bool))


def _what(value: object) -> str:
    return ("text" if isinstance(value, str) else "a bool" if isinstance(value, bool) else
            "a whole number" if isinstance(value, int) else "a number")


def check_settings(system, settings) -> None:
    """Each INSTANCE.NAME=VALUE of the system's own FMUs (a name the FMU does not have is the FMU's to refuse)."""
    from ...engine.fmi.model_description import read_fmu

    names = {i.name: i for i in system.instances}
    for key, value in settings:
        instance, _, name = key.partition(".")
        if instance not in names:
            continue
        variable = next((v for v in read_fmu(names[instance].fmu, instance).modelVariables if v.name == name), None)
        if variable is not None and not _fits(variable.type, value):
            raise UserError(f"--set {key}={value}: {name} is a {variable.type} parameter of {instance}, got {_what(value)}")

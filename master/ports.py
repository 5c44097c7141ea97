"""The controller port contract (docs/ports.md), checked on a model description before any step."""

from __future__ import annotations

from .system import DescriptionError

REQUIRED_OUTPUTS = ("f_R", "f_L", "tau_R", "tau_L")


def check_controller(md) -> None:
    """Refuse a controller FMU that lacks a required output or declares it with the wrong type or causality."""
    found = {v.name: v for v in md.modelVariables}
    for name in REQUIRED_OUTPUTS:
        v = found.get(name)
        if v is None:
            raise DescriptionError(f"controller FMU {md.modelName}: missing required output '{name}' (docs/ports.md)")
        if v.causality != "output":
            raise DescriptionError(f"controller FMU {md.modelName}: '{name}' must be an output, it is a {v.causality}")
        if v.type != "Real":
            raise DescriptionError(f"controller FMU {md.modelName}: '{name}' must be Real, it is {v.type}")

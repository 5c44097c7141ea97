"""A fault schedule's vocabulary: the actions, the JSON schema of a fault, the Fault itself and its log form. What each
action does: docs/faults.md."""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..errors import DescriptionError

ACTIONS = ("override", "bias", "scale", "ramp", "clamp", "hold", "noise", "dropout", "delay", "stale", "jitter")
VALUE_ACTIONS = ("override", "bias", "scale", "ramp", "clamp", "hold")  # functions of time and value only
SEEDS = 2**64  # seeds are 0..SEEDS-1: the words the kernel's draws take (tl_draw.c)
TICK_ACTIONS = {"delay", "stale", "jitter"}  # their value is a whole number of ticks

SCHEMA = {
    "type": "array", "items": {
        "type": "object", "additionalProperties": False, "required": ["action", "start"],
        "properties": {
            "name": {"type": "string"},
            "target": {"type": "string", "pattern": r"^[A-Za-z_][\w]*\.[A-Za-z_][\w]*$"},
            "targets": {"type": "array", "minItems": 1, "items": {"type": "string", "pattern": r"^[A-Za-z_][\w]*\.[A-Za-z_][\w]*$"}},
            "action": {"enum": list(ACTIONS)},
            "start": {"type": "number", "minimum": 0},
            "end": {"type": ["number", "null"], "minimum": 0},
            "value": {"type": ["number", "array", "boolean"]},
            "flag": {"type": "string", "pattern": r"^[A-Za-z_][\w]*\.[A-Za-z_][\w]*$"},
            "seed": {"type": "integer", "minimum": 0, "maximum": SEEDS - 1}}}}


class FaultError(DescriptionError):
    """A fault schedule that cannot be applied; the message names the fault and the field."""


@dataclass
class Fault:
    action: str
    targets: list[str]
    start: float
    end: float | None = None
    value: object = None
    flag: str | None = None
    seed: int = 0
    name: str = ""

    def label(self) -> str:
        return self.name or f"{self.action} {', '.join(self.targets)}"

    def active(self, t: float) -> bool:
        return self.start <= t + 1e-9 and (self.end is None or t + 1e-9 < self.end)



def describe(fault: Fault) -> dict:
    value = fault.value
    if isinstance(value, float) and not math.isfinite(value):
        value = str(value)
    return {"name": fault.label(), "action": fault.action, "targets": fault.targets, "start": fault.start,
            "end": fault.end, "value": value, "flag": fault.flag}

"""One declaration per FMU variable: the single source of the modelDescription.xml and the C tables."""

from __future__ import annotations

import re
from dataclasses import dataclass, field

TYPES = ("Real", "Integer", "Boolean", "String")
CAUSALITIES = ("parameter", "input", "output")
_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")


class DefinitionError(ValueError):
    """An FMU variable table that cannot describe a valid FMU."""


@dataclass(frozen=True)
class Variable:
    """One scalar variable. Parameters are fixed unless declared tunable (settable between steps: a run continued
    from a snapshot may change them); outputs are calculated at initialization."""

    name: str
    type: str
    causality: str
    start: float | int | bool | str
    description: str = ""
    unit: str = ""  # Real only; "" is dimensionless without a unit
    discrete: bool = False  # a Real that changes only at communication points (held samples)
    minimum: float | None = None  # declared range (min/max in the model description), Real and Integer
    maximum: float | None = None
    tunable: bool = False  # parameters only: the model reads it afresh at every step

    @property
    def variability(self) -> str:
        if self.causality == "parameter":
            return "tunable" if self.tunable else "fixed"
        return "continuous" if self.type == "Real" and not self.discrete else "discrete"

    @property
    def has_start(self) -> bool:
        return self.causality != "output"


@dataclass
class FmuDefinition:
    """What a native FMU is: its identity, its variables in value-reference order per type, its experiment."""

    model_identifier: str
    description: str
    variables: list[Variable]
    model_header: str  # the model's own header, declaring struct TlModelState
    default_experiment: tuple[float, float, float]  # start, stop, step (s)
    variable_step: bool = True  # canHandleVariableCommunicationStepSize
    version: str = "0"
    value_references: dict[str, int] = field(init=False)

    def __post_init__(self) -> None:
        seen: set[str] = set()
        counters = dict.fromkeys(TYPES, 0)
        self.value_references = {}
        for v in self.variables:
            if not _IDENTIFIER.match(v.name):
                raise DefinitionError(f"{self.model_identifier}: variable name {v.name!r} is not a C identifier")
            if v.name in seen:
                raise DefinitionError(f"{self.model_identifier}: variable {v.name!r} declared twice")
            if v.type not in TYPES or v.causality not in CAUSALITIES:
                raise DefinitionError(f"{self.model_identifier}.{v.name}: type {v.type!r} / causality {v.causality!r}")
            if v.unit and v.type != "Real":
                raise DefinitionError(f"{self.model_identifier}.{v.name}: only Reals carry units")
            if v.tunable and v.causality != "parameter":
                raise DefinitionError(f"{self.model_identifier}.{v.name}: only parameters are tunable")
            seen.add(v.name)
            self.value_references[v.name] = counters[v.type]
            counters[v.type] += 1

    def of_type(self, type_: str) -> list[Variable]:
        return [v for v in self.variables if v.type == type_]

    def vr(self, name: str) -> int:
        return self.value_references[name]

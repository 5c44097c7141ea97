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
class Clock:
    """An FMI 3.0 periodic time-based input clock: the importer activates it at 0, interval, 2 interval, ...
    (intervalVariability constant, no shift). Variables that belong to it name it in Variable.clock."""

    name: str
    interval: float  # s
    description: str = ""
    priority: int | None = None  # Scheduled Execution: the partition's priority (smaller runs first; the standard's rule)


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
    clock: str = ""  # FMI 3.0: the clock this input or output belongs to (then it is discrete)

    @property
    def variability(self) -> str:
        if self.causality == "parameter":
            return "tunable" if self.tunable else "fixed"
        return "continuous" if self.type == "Real" and not self.discrete and not self.clock else "discrete"

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
    clocks: tuple[Clock, ...] = ()  # FMI 3.0 input clocks (a clocked FMU is FMI 3.0 only)
    string_length: int = 64  # the longest String value + 1 (TL_STRING_LEN: each String's room in the state)
    scheduled: bool = False  # FMI 3.0 Scheduled Execution: one model partition per clock instead of co-simulation
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
        self._check_clocks(seen)

    def _check_clocks(self, names: set[str]) -> None:
        clocks = {}
        for k in self.clocks:
            if not _IDENTIFIER.match(k.name) or k.name in names or k.name in clocks:
                raise DefinitionError(f"{self.model_identifier}: clock name {k.name!r} is not a new C identifier")
            if not (isinstance(k.interval, float) and k.interval > 0 and k.interval < float("inf")):
                raise DefinitionError(f"{self.model_identifier}.{k.name}: interval must be a positive time, got {k.interval!r}")
            if self.scheduled and not (isinstance(k.priority, int) and k.priority >= 0):
                raise DefinitionError(f"{self.model_identifier}.{k.name}: Scheduled Execution needs a priority per clock, "
                                      f"got {k.priority!r}")
            clocks[k.name] = k
        if self.scheduled and not clocks:
            raise DefinitionError(f"{self.model_identifier}: Scheduled Execution needs at least one clock (its partitions)")
        for v in self.variables:
            if not v.clock:
                continue
            if v.clock not in clocks:
                raise DefinitionError(f"{self.model_identifier}.{v.name}: no clock {v.clock!r}")
            if v.causality == "parameter" or v.type == "String":
                raise DefinitionError(f"{self.model_identifier}.{v.name}: only inputs and outputs of type Real, Integer "
                                      "or Boolean can be clocked")

    def clock_index(self, name: str) -> int:
        return next(i for i, k in enumerate(self.clocks) if k.name == name)

    def of_type(self, type_: str) -> list[Variable]:
        return [v for v in self.variables if v.type == type_]

    def vr(self, name: str) -> int:
        return self.value_references[name]

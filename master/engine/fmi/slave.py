"""The slave interface: what the execution, the manipulators and the observers use of one FMU instance.

Three implementations: an FMU loaded into this process, FMI 2.0 (fmi2.InProcessFmu) or FMI 3.0 (fmi3.Fmu3Slave,
picked by in_process.load; what the two bindings share is binding.py), and an FMU of either version hosted in a
worker process or on `tiltload serve` (isolation.process.IsolatedFmu, whose worker steps the in-process slave).
All keep the outputs in typed arrays, `values[type]`, read after every step, and offer raw setters with the
fmi2Set<type> signature, so the execution moves values between them without knowing where an FMU runs.
"""

from __future__ import annotations

import ctypes
from abc import ABC, abstractmethod
from pathlib import Path

import numpy as np

from ..errors import ExecutionError

TYPES = ("Real", "Integer", "Boolean")  # the types connections carry, in the order outputs are read
C_TYPES = {"Real": ctypes.c_double, "Integer": ctypes.c_int, "Boolean": ctypes.c_int}  # fmi2Boolean is an int
FATAL = 4
STATUS = {1: "warning", 2: "discard", 3: "error", 4: "fatal", 5: "pending"}


class Slave(ABC):
    """One FMU instance as the engine sees it: the attributes below and the methods, nothing else."""

    name: str  # the instance's name in the system
    path: Path
    md: object  # its model description (model_description.read_fmu)
    values: dict[str, np.ndarray]  # values[type]: the outputs of that type, in model-description order (out_vrs[type])
    setters: dict[str, object]  # setters[type](component, vrs, n, values): sets inputs, returns an FMI status
    component: object  # what the setters take as their first argument
    outputs: dict[str, list]  # the output variables of each type
    out_vrs: dict[str, list[int]]
    out_index: dict[str, dict[int, int]]  # type -> value reference -> its index in values[type]
    vars: dict[str, object]  # every variable by name
    log: list[str]  # the FMU's log lines
    fatal: bool  # the instance reported a Fatal status: no further call is allowed
    fmi_seconds: float  # wall time spent in the FMU's calls

    def __init__(self, name: str, path: Path, md) -> None:
        self.name, self.path, self.md = name, Path(path), md
        self.log: list[str] = []
        self.fatal = False
        self.fmi_seconds = 0.0
        self.outputs = {t: [v for v in md.modelVariables if v.causality == "output" and v.type == t] for t in TYPES}
        self.out_vrs = {t: [v.valueReference for v in vs] for t, vs in self.outputs.items()}
        self.out_index = {t: {v.valueReference: i for i, v in enumerate(vs)} for t, vs in self.outputs.items()}
        self.vars = {v.name: v for v in md.modelVariables}
        self.values: dict[str, np.ndarray] = {}
        self.text_outputs: list = []  # String and Binary outputs this slave reads (read_texts), not carried in values
        self.texts: dict[str, object] = {}  # their values after the last read
        self.setters: dict[str, object] = {}
        self.component = None  # what the setters take as their first argument

    def failed(self, what: str, status: int) -> ExecutionError:
        """The error for a failed call: the status, and the FMU's last words."""
        self.fatal = status == FATAL
        said = next((line for line in reversed(self.log) if line.strip() and "Fatal py exception" not in line), "")
        return ExecutionError(f"{self.name}: {what} failed ({STATUS.get(status, status)})" + (f": {said}" if said else ""))

    @abstractmethod
    def initialize(self, parameters: dict) -> None:
        """Set-up at t = 0, the parameters, initialization mode; then the outputs at t = 0 are in values."""

    @abstractmethod
    def reset(self) -> None:
        """fmi2Reset: back to the state after instantiation."""

    @abstractmethod
    def do_step(self, t: float, h: float) -> None:
        """fmi2DoStep(t, h), with the inputs the setters gave since the last step."""

    @abstractmethod
    def read_outputs(self) -> None:
        """The outputs after the last step into values."""

    @property
    def can_serialize(self) -> bool:
        """Can its state be saved to bytes and restored (canGetAndSetFMUstate and canSerializeFMUstate)?"""
        cs = self.md.coSimulation
        return bool(cs.canGetAndSetFMUstate and cs.canSerializeFMUstate)

    @abstractmethod
    def set_values(self, values: dict) -> None:
        """Set parameters or inputs by name, each checked against its variable (model_description.checked_value)."""

    @abstractmethod
    def get_state(self) -> bytes:
        """The instance's whole state, serialized by the FMU (fmi2GetFMUstate + fmi2SerializeFMUstate)."""

    @abstractmethod
    def set_state(self, state: bytes) -> None:
        """Restore a state get_state gave (fmi2DeSerializeFMUstate + fmi2SetFMUstate); the outputs follow."""

    @abstractmethod
    def close(self) -> None:
        """Terminate and free the instance (no call after fmi2Fatal); safe to call twice."""

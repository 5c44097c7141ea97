"""Variable bookkeeping shared by the tiltload pythonfmu slaves (bundled into every FMU).

All Reals live in one numpy array indexed by value reference, so a slave reads inputs and
writes outputs as array slices and no attribute can shadow a variable (DESIGN §6). Reals must
be registered first, so that their value references are 0..n-1; other types follow.
"""

from __future__ import annotations

import numpy as np
from pythonfmu import Boolean, Fmi2Causality, Fmi2Variability, Integer, Real, String
from pythonfmu.enums import Fmi2Initial, Fmi2Status

OUT, INPUT, PARAM = Fmi2Causality.output, Fmi2Causality.input, Fmi2Causality.parameter
CONT, DISCRETE, FIXED = Fmi2Variability.continuous, Fmi2Variability.discrete, Fmi2Variability.fixed
EXACT = Fmi2Initial.exact


class VariableTable:
    def __init__(self, slave) -> None:
        self.slave = slave
        self._starts: list[float] = []
        self.v = np.zeros(0)
        self.names: dict[int, str] = {}
        self.inputs: set[int] = set()
        self.params: set[int] = set()
        self.other: dict[str, object] = {}  # non-Real values by name
        self.initialized = False

    def real(self, name, start, causality, variability, desc, unit="") -> int:
        vr = len(self._starts)
        if len(self.slave.vars) != vr:
            raise RuntimeError("register every Real before any other type")
        self._starts.append(float(start))
        initial = EXACT if causality == OUT else None
        self.slave.register_variable(Real(
            name, start=float(start), causality=causality, variability=variability, initial=initial,
            description=f"{desc} [{unit}]" if unit else desc,
            getter=lambda vr=vr: float(self.v[vr]), setter=lambda value, vr=vr: self.set(vr, value)))
        self.names[vr] = name
        (self.inputs if causality == INPUT else self.params if causality == PARAM else set()).add(vr)
        return vr

    def block(self, names, starts, causality, variability, desc, unit="") -> slice:
        vrs = [self.real(n, s, causality, variability, desc(n) if callable(desc) else desc, unit) for n, s in zip(names, starts)]
        return slice(vrs[0], vrs[-1] + 1)

    def freeze(self) -> np.ndarray:
        self.v = np.array(self._starts, dtype=float)
        return self.v

    def typed(self, kind, name, start, causality, desc):
        """An Integer, Boolean or String variable kept in self.other (parameters and flags)."""
        self.other[name] = start
        variability = FIXED if causality == PARAM else DISCRETE
        initial = EXACT if causality == OUT else None
        cls = {"integer": Integer, "boolean": Boolean, "string": String}[kind]

        def setter(value, name=name):
            if self.initialized and causality == PARAM:
                self.slave.log(f"cannot set {name} after initialization", Fmi2Status.error)
                raise ValueError(f"cannot set {name}")
            self.other[name] = value
        self.slave.register_variable(cls(name, start=start, causality=causality, variability=variability,
                                         initial=initial, description=desc,
                                         getter=lambda name=name: self.other[name], setter=setter))

    def set(self, vr, value) -> None:
        if vr in self.inputs or (vr in self.params and not self.initialized):
            self.v[vr] = value
            return
        what = "a parameter after initialization" if vr in self.params else "an output"
        self.slave.log(f"cannot set {self.names[vr]}: it is {what}", Fmi2Status.error)
        raise ValueError(f"cannot set {self.names[vr]}")

    def get_real(self, vrs):
        return self.v[vrs].tolist()

    def set_real(self, vrs, values):
        if self.initialized and self.inputs.issuperset(vrs):
            self.v[vrs] = values
            return
        for vr, value in zip(vrs, values):
            self.set(vr, value)

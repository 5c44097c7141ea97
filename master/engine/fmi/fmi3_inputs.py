"""An FMI 3.0 FMU's inputs as the execution sets them (fmi3.py): each carrier's values staged in FMI 3.0 buffers, split
by when the standard lets them be set (continuous in Step Mode, discrete and clocked in Event Mode) and by their own
FMI 3.0 type where it is not their carrier's (an Int8 carried as an Integer is set with fmi3SetInt8)."""

from __future__ import annotations

import ctypes

import numpy as np

from .model_description import FMI_TYPES

FMI3_C = {"Real": ctypes.c_double, "Integer": ctypes.c_int32, "Boolean": ctypes.c_bool}  # fmi3Float64, Int32, Boolean
FMI3_NAME = {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean"}  # each carrier's own FMI 3.0 type
# The FMI 3.0 get and set functions of every carried type (an Enumeration's are Int64's)
API = {name: "Int64" if name == "Enumeration" else name for name, kind in FMI_TYPES.items() if kind.carrier is not None}


def api_type(slave, t: str, vr: int) -> str:
    """The FMI 3.0 function type of a carried variable (by its carrier t and value reference)."""
    return slave.api.get((t, vr), FMI3_NAME[t])


class StagedInputs:
    """One setter call site of the execution (its value-reference array): the values staged in FMI 3.0 buffers, split
    by when they may be set (continuous, discrete, or clocked by clock j)."""

    def __init__(self, slave, t: str, vrs, n: int) -> None:
        self.type, self.n = t, n
        kinds: dict[tuple, list[int]] = {}
        for i in range(n):
            kinds.setdefault((slave.input_kind.get((t, vrs[i]), "continuous"), api_type(slave, t, vrs[i])), []).append(i)
        self.buffer = (FMI3_C[t] * n)()
        self.staged = np.ctypeslib.as_array(self.buffer)
        self.sources: dict[int, np.ndarray] = {}  # address of a values buffer the execution sets from -> its view
        self.parts = []  # (kind, vrs, n, buffer, its view, indices into staged; None: the whole buffer, FMI 3.0 type)
        for (kind, api), idx in kinds.items():
            part_vrs = (ctypes.c_uint * len(idx))(*[vrs[i] for i in idx])
            if len(kinds) == 1 and api == FMI3_NAME[t]:
                self.parts.append((kind, part_vrs, n, self.buffer, self.staged, None, api))
            else:
                buf = (FMI_TYPES[api].c_type * len(idx))()
                self.parts.append((kind, part_vrs, len(idx), buf, np.ctypeslib.as_array(buf), np.array(idx), api))
        self.discrete = [p for p in self.parts if p[0] == "discrete"]
        self.applied: dict[int, np.ndarray] = {}  # discrete part -> the values last set

    def stage(self, values) -> None:
        view = self.sources.get(ctypes.addressof(values))
        if view is None:
            view = self.sources[ctypes.addressof(values)] = np.ctypeslib.as_array(values)[:self.n]
        self.staged[:] = view

    def changed_discrete(self) -> bool:
        return any(not np.array_equal(self.staged if idx is None else self.staged[idx], self.applied.get(id(vrs)))
                   for _, vrs, _, _, _, idx, _ in self.discrete)

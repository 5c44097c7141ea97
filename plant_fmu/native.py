"""Run-time access to the compiled plant through ctypes: no CasADi, no compiler needed.

This is the code the plant FMU executes; it holds no model of its own. Buffers are bound
once, so a communication step costs one foreign call.
"""

from __future__ import annotations

import ctypes
from pathlib import Path

import numpy as np

from .interface import DIAGNOSTIC_NAMES, STATE_NAMES

NX = len(STATE_NAMES)
NY = len(DIAGNOSTIC_NAMES)

_dbl_p = ctypes.POINTER(ctypes.c_double)


def _ptr(a: np.ndarray):
    if a.dtype != np.float64 or not a.flags.c_contiguous:
        raise ValueError("plant buffers must be C-contiguous float64 arrays")
    return a.ctypes.data_as(_dbl_p)


class NativePlant:
    """The compiled plant library: advance a state over n RK4 substeps, evaluate outputs."""

    def __init__(self, library: Path | str) -> None:
        self._lib = ctypes.CDLL(str(library))
        for name, argtypes in (
            ("tl_plant_advance", [_dbl_p, _dbl_p, _dbl_p, ctypes.c_double, ctypes.c_int, _dbl_p, _dbl_p]),
            ("tl_plant_outputs", [_dbl_p, _dbl_p, _dbl_p]),
            ("tl_plant_xdot", [_dbl_p, _dbl_p, _dbl_p, _dbl_p, _dbl_p]),
        ):
            fn = getattr(self._lib, name)
            fn.argtypes = argtypes
            fn.restype = ctypes.c_int
        self._advance = self._lib.tl_plant_advance
        self._outputs = self._lib.tl_plant_outputs
        self._xdot = self._lib.tl_plant_xdot
        self._bound = None

    def bind(self, x: np.ndarray, u: np.ndarray, d: np.ndarray, p: np.ndarray, y: np.ndarray) -> None:
        """Fix the buffers step() and evaluate() work on (views into one array are fine)."""
        self._keep = (x, u, d, p, y)  # the pointers below live as long as these arrays
        self._bound = tuple(_ptr(a) for a in self._keep)

    def step(self, h: float, n: int) -> int:
        """Advance the bound state by n substeps of h and refresh y, in one foreign call.

        0 if fine; k > 0 if substep k went non-finite, -1 if the model failed: then x and y
        keep their previous values.
        """
        x, u, d, p, y = self._bound
        return self._advance(u, d, p, h, n, x, y)

    def evaluate(self) -> None:
        """Outputs (UAV pose, energies, momenta) of the bound state into y."""
        x, _, _, p, y = self._bound
        if self._outputs(x, p, y):
            raise RuntimeError("plant output evaluation failed")

    # Convenience calls on fresh arrays (tests, tools); the FMU uses bind/step/evaluate.
    def advance(self, x0, u, d, p, h: float, n: int) -> tuple[int, np.ndarray]:
        u, d, p = (np.ascontiguousarray(a, dtype=float) for a in (u, d, p))
        x = np.array(x0, dtype=float)
        y = np.empty(NY)
        status = self._advance(_ptr(u), _ptr(d), _ptr(p), h, n, _ptr(x), _ptr(y))
        return status, x

    def xdot(self, x, u, d, p) -> np.ndarray:
        arrays = [np.ascontiguousarray(a, dtype=float) for a in (x, u, d, p)]
        r = np.empty(NX)
        if self._xdot(*map(_ptr, arrays), _ptr(r)):
            raise RuntimeError("plant derivative evaluation failed")
        return r


class CasadiFunction:
    """Call one CasADi-generated C function of the library (the standard casadi_* API) on numpy arrays.

    Work arrays are allocated once; outputs are written into caller-provided arrays.
    """

    def __init__(self, library: Path | str | ctypes.CDLL, name: str) -> None:
        lib = library if isinstance(library, ctypes.CDLL) else ctypes.CDLL(str(library))
        cint = ctypes.c_longlong
        work = getattr(lib, f"{name}_work")
        work.argtypes = [ctypes.POINTER(cint)] * 4
        work.restype = ctypes.c_int
        sizes = [cint() for _ in range(4)]
        if work(*(ctypes.byref(v) for v in sizes)):
            raise RuntimeError(f"{name}: work size query failed")
        n_arg, n_res, n_iw, n_w = (v.value for v in sizes)
        self._fn = getattr(lib, name)
        self._fn.argtypes = [ctypes.POINTER(_dbl_p), ctypes.POINTER(_dbl_p), ctypes.POINTER(cint), _dbl_p, ctypes.c_int]
        self._fn.restype = ctypes.c_int
        self._arg = (_dbl_p * max(n_arg, 1))()
        self._res = (_dbl_p * max(n_res, 1))()
        self._iw = (cint * max(n_iw, 1))()
        self._w = np.zeros(max(n_w, 1))
        self._w_ptr = _ptr(self._w)
        self.name = name

    def __call__(self, inputs: list[np.ndarray], outputs: list[np.ndarray]) -> None:
        for i, a in enumerate(inputs):
            self._arg[i] = _ptr(a)
        for i, a in enumerate(outputs):
            self._res[i] = _ptr(a)
        if self._fn(self._arg, self._res, self._iw, self._w_ptr, 0):
            raise RuntimeError(f"{self.name}: evaluation failed")

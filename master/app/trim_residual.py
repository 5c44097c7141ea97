"""The trim's residual and Jacobian (plant_fmu.trim.residual_function) compiled to C by CasADi's code generator, built
once per machine (engine/native/kernel.compiled: cached by the generated source's digest) and called with ctypes: about
3 us a call where CasADi's virtual machine takes 25. The generated code performs the virtual machine's operations in
its order (-ffp-contract=off: no fused multiply-add), so a trim is the same to the last bit (tests/app/test_throughput.py
compares the two on the feasibility check's Newton steps). Without a C compiler the virtual machine is used."""

from __future__ import annotations

import ctypes
import tempfile
import threading
from pathlib import Path

import numpy as np

from ..engine.native.kernel import CFLAGS, KernelError, compiled

FLAGS = tuple(f for f in CFLAGS if f not in ("-fvisibility=hidden", "-Wall", "-Wextra"))  # generated code: its exports
_local = threading.local()
_libraries: dict[str, ctypes.CDLL | None] = {}
_lock = threading.Lock()


def _library(vehicle: str) -> ctypes.CDLL | None:
    """The compiled residual of a vehicle (None: no compiler)."""
    import casadi as ca

    from ...plant_fmu.trim import residual_function

    with _lock:
        if vehicle not in _libraries:
            generator = ca.CodeGenerator(f"tl_trim_{vehicle}.c", {"with_header": False})
            generator.add(residual_function(vehicle))
            with tempfile.TemporaryDirectory(prefix="tiltload-trim-") as tmp:
                source = Path(tmp) / f"tl_trim_{vehicle}.c"
                source.write_text(generator.dump())
                try:
                    _libraries[vehicle] = compiled(f"tl_trim_{vehicle}", [source], FLAGS, ("m",))
                except KernelError:
                    _libraries[vehicle] = None
        return _libraries[vehicle]


class CompiledResidual:
    """(residual, dense Jacobian) of a trim point, as plant_fmu.trim's _Residual gives them; one per thread."""

    def __init__(self, vehicle: str, lib: ctypes.CDLL) -> None:
        from ...plant_fmu.trim import residual_function

        f = residual_function(vehicle)
        self.function = lib.trim_residual
        sizes = [ctypes.c_longlong() for _ in range(4)]
        lib.trim_residual_work(*(ctypes.byref(s) for s in sizes))
        n_arg, n_res, n_iw, n_w = (s.value for s in sizes)
        self.z, self.ref, self.p = (np.zeros(f.nnz_in(k)) for k in range(3))
        self.r, self.nonzeros = np.zeros(f.nnz_out(0)), np.zeros(f.nnz_out(1))
        double_p = ctypes.POINTER(ctypes.c_double)
        self.args = (double_p * max(n_arg, 3))(*(a.ctypes.data_as(double_p) for a in (self.z, self.ref, self.p)))
        self.res = (double_p * max(n_res, 2))(*(a.ctypes.data_as(double_p) for a in (self.r, self.nonzeros)))
        self.iw = (ctypes.c_longlong * max(n_iw, 1))()
        self.w = (ctypes.c_double * max(n_w, 1))()
        self.function.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int]
        self.function.restype = ctypes.c_int
        rows, cols = f.sparsity_out(1).get_triplet()
        self.rows, self.cols, self.shape = np.array(rows), np.array(cols), f.sparsity_out(1).shape

    def __call__(self, z, ref, p) -> tuple[np.ndarray, np.ndarray]:
        self.z[:], self.ref[:], self.p[:] = z, ref, p
        if self.function(self.args, self.res, self.iw, self.w, 0):
            raise RuntimeError("the compiled trim residual failed")
        J = np.zeros(self.shape)
        J[self.rows, self.cols] = self.nonzeros
        return self.r.copy(), J


def compiled_residual(vehicle: str):
    """This thread's compiled residual of a vehicle; None without a C compiler (the caller uses the virtual machine)."""
    cached = _local.__dict__.setdefault("residuals", {})
    if vehicle not in cached:
        lib = _library(vehicle)
        cached[vehicle] = CompiledResidual(vehicle, lib) if lib is not None else None
    return cached[vehicle]

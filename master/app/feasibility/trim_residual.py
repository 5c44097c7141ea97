"""The feasibility check's Newton steps (plant_fmu.trim.newton) in C: CasADi's code generator writes the trim residual
and its Jacobian, and the residual alone (plant_fmu.trim.residual_functions); trim_newton.c takes the steps and solves
with the LAPACK dgesv numpy's linalg.solve itself calls (its address taken from numpy's own library), built once per machine
(engine/native/kernel.compiled: cached by the sources' digest) and called with ctypes. The same operations on the same
values in the same order (-ffp-contract=off: no fused multiply-add), so the same trims to the last bit
(tests/app/test_throughput.py); the trims along a path go in one call (tl_trim_path: trajectory_check._trim's
halving too). A plant's check takes about 1 ms where Python's steps took 40. Without a C compiler, or a numpy
whose dgesv cannot be found, plant_fmu.trim.newton runs."""

from __future__ import annotations

import ctypes
import glob
import os
import tempfile
import threading
from functools import cache
from pathlib import Path

import numpy as np

from ...engine.native.kernel import CFLAGS, KernelError, compiled

FLAGS = tuple(f for f in CFLAGS if f not in ("-fvisibility=hidden", "-Wall", "-Wextra"))  # CasADi's generated code
SOURCE = Path(__file__).with_name("trim_newton.c")
MISSION = Path(__file__).with_name("mission_samples.c")  # with the scenario FMU's own waypoint arithmetic
SCENARIO_C = Path(__file__).resolve().parents[3] / "scenario_fmu" / "c"  # tiltload/master/app/feasibility/ -> tiltload/
PLATFORM_C = Path(__file__).resolve().parents[3] / "native_fmu" / "c"
_local = threading.local()
_libraries: dict[str, ctypes.CDLL | None] = {}
_lock = threading.Lock()


@cache
def feedforward(vehicle: str):
    """The controller's feedforward (3.18) as a CasADi function (the feasibility check's)."""
    from ....plant_fmu.codegen import feedforward_function

    return feedforward_function(vehicle)


def along_reference(nq: int) -> tuple[int, ...]:
    """The state's entries a reference row sets (the load's position, psi and their rates: tl_feedforward_along); the
    others are the hover trim's angles and zero rates, the same at every row."""
    return (0, 1, 2, 5, nq, nq + 1, nq + 2, nq + 5)


@cache
def feedforward_parts(vehicle: str):
    """The feedforward in two functions of the same operations: `fixed` (x, p) -> what depends only on the entries of x
    a reference row leaves as they are and on p (the hover attitude's trigonometry, its least-squares factor), computed
    once a reference; `rest` (x, qdd, p, fixed's values) -> u, computed at every row (CasADi's extract_parametric: the
    same expressions, the same bits; a third fewer operations a row)."""
    import casadi as ca

    f = feedforward(vehicle)
    x, qdd, p = ca.SX.sym("x", f.size1_in(0)), ca.SX.sym("qdd", f.size1_in(1)), ca.SX.sym("p", f.size1_in(2))
    same = [x[i] for i in range(x.numel()) if i not in along_reference(f.size1_in(1))]
    rest, symbols, values = ca.extract_parametric(f(x, qdd, p), ca.vertcat(*same, p))
    symbols, values = (ca.vertcat(*v) if isinstance(v, list) else v for v in (symbols, values))
    return (ca.Function("tl_feedforward_fixed", [x, p], [values]),
            ca.Function("tl_feedforward_rest", [x, qdd, p, symbols], [rest]))


def _gesv():
    """numpy's own LAPACK dgesv (its bundled OpenBLAS, 64-bit integers), or None."""
    libs = glob.glob(os.path.join(os.path.dirname(np.__file__), os.pardir, "numpy.libs", "libscipy_openblas64_*.so"))
    for path in libs:
        try:
            return ctypes.CDLL(path).scipy_dgesv_64_
        except (OSError, AttributeError):
            continue
    return None


def _library(vehicle: str) -> ctypes.CDLL | None:
    import casadi as ca

    from ....plant_fmu.trim import residual_functions
    from ....scenario_fmu.fmu_variables import capacity_header

    with _lock:
        if vehicle not in _libraries:
            generator = ca.CodeGenerator(f"tl_trim_{vehicle}.c", {"with_header": False})
            for function in (*residual_functions(vehicle), *feedforward_parts(vehicle)):
                generator.add(function)
            with tempfile.TemporaryDirectory(prefix="tiltload-trim-") as tmp:
                source = Path(tmp) / f"tl_trim_{vehicle}.c"
                source.write_text(generator.dump())
                capacity = Path(tmp) / "scenario_capacity.h"
                capacity.write_text(capacity_header())
                headers = [SCENARIO_C / "scenario_waypoints.h", PLATFORM_C / "tl_platform.h", capacity]
                includes = (f"-I{SCENARIO_C}", f"-I{PLATFORM_C}", f"-I{tmp}")
                try:
                    _libraries[vehicle] = compiled(f"tl_trim_{vehicle}", [source, SOURCE, MISSION, SCENARIO_C /
                                                   "scenario_waypoints.c", *headers], (*FLAGS, *includes), ("m",))
                except KernelError:
                    _libraries[vehicle] = None
        return _libraries[vehicle]


class CompiledNewton:
    """newton(vehicle, z, ref, p, tol, max_iter) of plant_fmu.trim for one vehicle, in C; one per thread (its work
    arrays)."""

    def __init__(self, vehicle: str, lib: ctypes.CDLL, gesv) -> None:
        from ....plant_fmu.trim import residual_function

        f = residual_function(vehicle)
        work = []
        for name in ("trim_residual_work", "trim_residual_value_work"):  # arrays for either function
            sizes = [ctypes.c_longlong() for _ in range(4)]
            getattr(lib, name)(*(ctypes.byref(s) for s in sizes))
            work.append((sizes[2].value, sizes[3].value))
        self.iw = np.zeros(max(1, *(i for i, _ in work)), dtype=np.int64)
        self.w = np.zeros(max(1, *(w for _, w in work)))
        rows, cols = f.sparsity_out(1).get_triplet()
        self.n = f.nnz_in(0)
        self.dense = np.array([c * f.size1_out(1) + r for r, c in zip(rows, cols)], dtype=np.int64)  # column-major
        self.gesv = ctypes.cast(gesv, ctypes.c_void_p)
        self.function = lib.tl_trim_newton
        p, i = ctypes.c_void_p, ctypes.c_int
        self.function.argtypes = [p, p, p, i, p, i, ctypes.c_double, i, p, p, p, ctypes.POINTER(ctypes.c_double),
                                  ctypes.POINTER(ctypes.c_int)]
        self.function.restype = i
        self.residual, self.iterations = ctypes.c_double(), ctypes.c_int()
        self.path_function = lib.tl_trim_path
        self.path_function.argtypes = [p, p, p, i, p, i, i, p, i, ctypes.c_double, i, p, p, p, p]
        self.path_function.restype = i
        self.z, self.ref, self.p = np.zeros(self.n), np.zeros(f.nnz_in(1)), np.zeros(f.nnz_in(2))
        self.addresses = [a.ctypes.data for a in (self.z, self.ref, self.p, self.dense, self.iw, self.w)]

    def path(self, z, previous, refs: np.ndarray, p, n_angles: int, tol: float, max_iter: int) -> np.ndarray:
        """trajectory_check's trims at each row of refs, each from the one before (z at previous first): the rows found
        (fewer than refs': none at the next)."""
        refs = np.ascontiguousarray(refs, dtype=float)
        z, previous, p = (np.ascontiguousarray(a, dtype=float) for a in (z, previous, p))
        trims = np.empty((len(refs), self.n))
        at = self.addresses
        done = self.path_function(z.ctypes.data, previous.ctypes.data, refs.ctypes.data, len(refs), p.ctypes.data, self.n,
                                  n_angles, at[3], len(self.dense), tol, max_iter, self.gesv, at[4], at[5], trims.ctypes.data)
        return trims[:done]

    def __call__(self, z, ref, p, tol: float, max_iter: int):
        self.z[:], self.ref[:], self.p[:] = z, ref, p
        at = self.addresses
        ok = self.function(at[0], at[1], at[2], self.n, at[3], len(self.dense), tol, max_iter, self.gesv, at[4], at[5],
                           ctypes.byref(self.residual), ctypes.byref(self.iterations))
        return (self.z.copy(), float(self.residual.value), int(self.iterations.value)) if ok else None  # a new z


def compiled_newton(vehicle: str):
    """This thread's compiled Newton of a vehicle; None when it cannot be built (the caller uses plant_fmu.trim's)."""
    cached = _local.__dict__.setdefault("newtons", {})
    if vehicle not in cached:
        gesv = _gesv()
        lib = _library(vehicle) if gesv is not None else None
        cached[vehicle] = CompiledNewton(vehicle, lib, gesv) if lib is not None else None
    return cached[vehicle]


class CompiledFeedforward:
    """trajectory_check's feedforward along the reference in C (tl_feedforward_along, over feedforward_parts): CasADi's
    map of it over states and accelerations made from the reference's rows, the same bits."""

    def __init__(self, vehicle: str, lib: ctypes.CDLL) -> None:
        f = feedforward(vehicle)
        parts = feedforward_parts(vehicle)
        work = []
        for part in parts:
            sizes = [ctypes.c_longlong() for _ in range(4)]
            getattr(lib, f"{part.name()}_work")(*(ctypes.byref(s) for s in sizes))
            work.append((sizes[2].value, sizes[3].value))
        self.iw = np.zeros(max(1, *(i for i, _ in work)), dtype=np.int64)
        self.w = np.zeros(max(1, *(w for _, w in work)))
        self.values = np.zeros(max(1, parts[0].nnz_out(0)))
        self.rows = [f.size1_in(k) for k in range(3)]
        self.nu = f.size1_out(0)
        self.functions = [ctypes.cast(getattr(lib, part.name()), ctypes.c_void_p) for part in parts]
        self.along = lib.tl_feedforward_along
        p, i = ctypes.c_void_p, ctypes.c_int
        self.along.argtypes = [p, p, p, i, p, i, p, p, p, i, i, p, p]
        self.along.restype = i

    def __call__(self, hover_x: np.ndarray, refs: np.ndarray, p: np.ndarray) -> np.ndarray:
        """u (count, nu) at the rows of refs (count, 11: the load's position, psi, their rates, its acceleration), the
        other coordinates at hover_x and at rest, with the parameters p."""
        hover_x, p = np.ascontiguousarray(hover_x, dtype=float), np.ascontiguousarray(p, dtype=float)
        if refs.dtype != np.float64 or refs.ndim != 2 or refs.strides[1] != 8 or refs.strides[0] % 8:
            refs = np.ascontiguousarray(refs, dtype=float)  # (rows apart by any whole number of doubles are read as they are)
        if hover_x.shape != (self.rows[0],) or p.shape != (self.rows[2],) or refs.ndim != 2 or refs.shape[1] != 11:
            raise ValueError(f"the feedforward takes a state of {self.rows[0]}, rows of 11 and {self.rows[2]} parameters, "
                             f"not {hover_x.shape}, {refs.shape} and {p.shape}")
        out = np.empty((len(refs), self.nu))
        status = self.along(*self.functions, hover_x.ctypes.data, self.rows[1], refs.ctypes.data, refs.strides[0] // 8,
                            p.ctypes.data, self.values.ctypes.data, out.ctypes.data, self.nu, len(refs),
                            self.iw.ctypes.data, self.w.ctypes.data)
        if status:
            raise RuntimeError(f"the compiled feedforward failed ({status})")
        return out


def compiled_feedforward(vehicle: str):
    """This thread's compiled feedforward of a vehicle; None when it cannot be built (the caller maps CasADi's)."""
    cached = _local.__dict__.setdefault("feedforwards", {})
    if vehicle not in cached:
        lib = _library(vehicle) if _gesv() is not None else None
        cached[vehicle] = CompiledFeedforward(vehicle, lib) if lib is not None else None
    return cached[vehicle]


class CompiledMission:
    """waypoints.MinimumJerk.evaluate by the scenario FMU's C (tl_mission_samples): the same bits
    (tests/app/test_throughput.py), 0.04 ms where numpy takes 0.12 for an 8 s reference."""

    def __init__(self, lib: ctypes.CDLL) -> None:
        self.function = lib.tl_mission_samples
        p, i = ctypes.c_void_p, ctypes.c_int
        self.function.argtypes = [i, p, p, p, p, i, p, p]
        self.function.restype = None

    def __call__(self, reference, times: np.ndarray) -> np.ndarray:
        """(len(times), 12): the position, velocity and acceleration of x, y, z, psi of a waypoints.MinimumJerk at the
        times (its first 11 columns a reference row of the trims and the feedforward)."""
        times = np.ascontiguousarray(times, dtype=float)
        knots = np.ascontiguousarray(reference.t, dtype=float)
        p, v, a = (np.ascontiguousarray(np.asarray(x, dtype=float).T) for x in (reference.p, reference.v, reference.a))
        if p.shape[0] != 4:
            raise ValueError(f"a mission has 4 axes (x, y, z, psi), not {p.shape[0]}")
        out = np.empty((times.size, 12))
        self.function(knots.size, knots.ctypes.data, p.ctypes.data, v.ctypes.data, a.ctypes.data, times.size,
                      times.ctypes.data, out.ctypes.data)
        return out


def compiled_mission(vehicle: str):
    """The compiled mission evaluation (built with the vehicle's feasibility library); None when it cannot be built
    (the caller evaluates waypoints.MinimumJerk in numpy)."""
    cached = _local.__dict__.setdefault("missions", {})
    if vehicle not in cached:
        lib = _library(vehicle) if _gesv() is not None else None
        cached[vehicle] = CompiledMission(lib) if lib is not None else None
    return cached[vehicle]

"""The controller FMU's C estimators (tl_zse.c, tl_lkf.c), compiled from the FMU's own sources/ into a
shared library and driven through ctypes with the Python estimators' interface: for the tests that
compare them with the Python reference, for the benchmarks, and for offline analysis with exactly
the estimator the FMU runs."""

from __future__ import annotations

import ctypes
import subprocess
import zipfile
from pathlib import Path

import numpy as np

from .zonotope import interval_hull
from .zse import StepReport

D = ctypes.POINTER(ctypes.c_double)
I = ctypes.POINTER(ctypes.c_int)
REDUCTION = {"combastel": 0, "girard": 1, "pca": 2}
FILES = ("tl_zse.c", "tl_lkf.c", "tl_linalg.c")


def compile_library(fmu: Path, folder: Path, extra: tuple[str, ...] = ()) -> Path:
    """The estimators exactly as shipped: the FMU's sources, the FMU's hot-kernel flags (and extra flags, e.g.
    -DTL_PORTABLE_FP for the baseline vector copy alone)."""
    from ...native_fmu.compile import HOT_CFLAGS

    with zipfile.ZipFile(fmu) as z:
        z.extractall(folder, [n for n in z.namelist() if n.startswith("sources/")])
    src = folder / "sources"
    lib = folder / "libestimators.so"
    subprocess.run(["cc", "-std=c11", *HOT_CFLAGS, *extra, "-fPIC", "-shared", "-DTL_INTERNAL=", f"-I{src}",
                    *(str(src / f) for f in FILES), "-o", str(lib), "-lm"], check=True)
    return lib


class _ZseModel(ctypes.Structure):
    _fields_ = [(n, D) for n in ("A", "B", "H", "c_w", "Gw", "sigma", "s", "hull_w", "Sw")] + \
               [(n, ctypes.c_int) for n in ("nu", "rw", "r_max", "reduction")]


class _Report(ctypes.Structure):
    _fields_ = [("used", ctypes.c_int), ("n_nonfinite", ctypes.c_int), ("n_inconsistent", ctypes.c_int),
                ("nonfinite", ctypes.c_int * 16), ("inconsistent", ctypes.c_int * 16)]


def _ptr(a: np.ndarray):
    return a.ctypes.data_as(D)


class CZonotopicEstimator:
    """Mirror of controller_fmu.zse.ZonotopicEstimator's interface, running the C code."""

    def __init__(self, lib: Path, A, B, H, c_w, G_w, c_v, G_v, r_max: int, reduction: str = "combastel"):
        self.lib = ctypes.CDLL(str(lib))
        self.lib.tl_zse_size.restype = ctypes.c_ulong
        self.lib.tl_zse_frobenius.restype = ctypes.c_double
        Gwt = np.ascontiguousarray(np.asarray(G_w, dtype=float).T)
        self._keep = {  # arrays the C model points into
            "A": np.ascontiguousarray(A, dtype=float), "B": np.ascontiguousarray(B, dtype=float),
            "H": np.ascontiguousarray(H, dtype=float), "c_w": np.ascontiguousarray(c_w, dtype=float), "Gw": Gwt,
            "sigma": np.ascontiguousarray(interval_hull(np.asarray(G_v, dtype=float).T)), "s": -np.asarray(c_v, dtype=float),
            "hull_w": interval_hull(Gwt), "Sw": Gwt.T @ Gwt}
        self.n, self.ny = self._keep["A"].shape[0], self._keep["H"].shape[0]
        self.model = _ZseModel(**{k: _ptr(v) for k, v in self._keep.items()}, nu=self._keep["B"].shape[1], rw=Gwt.shape[0],
                               r_max=int(r_max), reduction=REDUCTION[reduction])
        self.buf = ctypes.create_string_buffer(self.lib.tl_zse_size())
        self.report = _Report()
        n = self.n
        # TlZse: int r, cur, steps; then c (n), S (n x n), hull (n), G[2][cap][ld]
        self._c = np.frombuffer(self.buf, dtype=np.float64, count=n, offset=16)
        self._S = np.frombuffer(self.buf, dtype=np.float64, count=n * n, offset=16 + 8 * n).reshape(n, n)
        self._hull = np.frombuffer(self.buf, dtype=np.float64, count=n, offset=16 + 8 * (n + n * n))
        self.ld = (n + 3) // 4 * 4
        g_offset = 16 + 8 * (2 * n + n * n)  # TlZse: 3 ints (padded to 16 bytes), c, S, hull, then G[2][cap][ld]
        self.cap = (self.lib.tl_zse_size() - g_offset) // (2 * self.ld * 8)
        self._G = np.frombuffer(self.buf, dtype=np.float64, count=2 * self.cap * self.ld, offset=g_offset).reshape(2, self.cap, self.ld)

    def _result(self) -> StepReport:
        rep = self.report
        return StepReport(rep.used, list(rep.nonfinite[: rep.n_nonfinite]), list(rep.inconsistent[: rep.n_inconsistent]))

    def _avail(self, available):
        a = np.ones(self.ny, dtype=np.int32) if available is None else np.asarray(available, dtype=np.int32)
        return np.ascontiguousarray(a)

    def initialize(self, c0, G0, y0=None, available=None):
        G0t = np.ascontiguousarray(np.asarray(G0, dtype=float).T)
        y = None if y0 is None else np.ascontiguousarray(y0, dtype=float)
        a = self._avail(available)
        rc = self.lib.tl_zse_initialize(self.buf, ctypes.byref(self.model), _ptr(np.ascontiguousarray(c0, dtype=float)),
                                        _ptr(G0t), G0t.shape[0], None if y is None else _ptr(y), a.ctypes.data_as(I),
                                        ctypes.byref(self.report))
        assert rc == 0
        return self._result()

    def step(self, du, y, available=None):
        a = self._avail(available)
        rc = self.lib.tl_zse_step(self.buf, ctypes.byref(self.model), _ptr(np.ascontiguousarray(du, dtype=float)),
                                  _ptr(np.ascontiguousarray(y, dtype=float)), a.ctypes.data_as(I), ctypes.byref(self.report))
        assert rc == 0
        return self._result()

    @property
    def r(self) -> int:
        return int(np.frombuffer(self.buf, dtype=np.int32, count=1)[0])

    @property
    def c(self) -> np.ndarray:
        return self._c.copy()

    @property
    def hull(self) -> np.ndarray:
        return self._hull.copy()

    @property
    def Gt(self) -> np.ndarray:
        """The generators as rows (r x n): a view into the C estimator's current buffer."""
        cur = int(np.frombuffer(self.buf, dtype=np.int32, count=2)[1])
        return self._G[cur, : self.r, : self.n]

    def frobenius(self) -> float:
        return float(self.lib.tl_zse_frobenius(self.buf))


class _LkfModel(ctypes.Structure):
    _fields_ = [(n, D) for n in ("A", "B", "H", "Pw", "Pv")] + [("nu", ctypes.c_int)]


class CKalmanFilter:
    """Mirror of controller_fmu.lkf.KalmanFilter's interface, running the C code."""

    def __init__(self, lib: Path, A, B, H, Pw, Pv, nu0, P0):
        self.lib = ctypes.CDLL(str(lib))
        self.lib.tl_lkf_size.restype = ctypes.c_ulong
        self._keep = {k: np.ascontiguousarray(v, dtype=float) for k, v in dict(A=A, B=B, H=H, Pw=Pw, Pv=Pv).items()}
        self.model = _LkfModel(**{k: _ptr(v) for k, v in self._keep.items()}, nu=self._keep["B"].shape[1])
        self.buf = ctypes.create_string_buffer(self.lib.tl_lkf_size())
        n = self._keep["A"].shape[0]
        self.lib.tl_lkf_initialize(self.buf, _ptr(np.ascontiguousarray(nu0, dtype=float)), _ptr(np.ascontiguousarray(P0, dtype=float)))
        self._nu = np.frombuffer(self.buf, dtype=np.float64, count=n)
        self._P = np.frombuffer(self.buf, dtype=np.float64, count=n * n, offset=8 * n).reshape(n, n)
        self.ny = self._keep["H"].shape[0]

    @property
    def nu(self):
        return self._nu.copy()

    @property
    def P(self):
        return self._P.copy()

    def step(self, du, dy, available=None) -> list[int]:
        skipped = (ctypes.c_int * self.ny)()
        count = ctypes.c_int()
        a = None if available is None else np.ascontiguousarray(available, dtype=np.int32)
        rc = self.lib.tl_lkf_step(self.buf, ctypes.byref(self.model), _ptr(np.ascontiguousarray(du, dtype=float)),
                                  _ptr(np.ascontiguousarray(dy, dtype=float)), None if a is None else a.ctypes.data_as(I),
                                  skipped, ctypes.byref(count))
        assert rc == 0
        return list(skipped[: count.value])

"""Generate the plant's C code with CasADi (build time only): the one source of the compiled model.

The native plant FMU compiles tl_plant_gen.c (one RK4 substep and the diagnostic outputs) into
its binary. The controller FMU, still a Python FMU until it is ported, loads a small shared
library with the feedforward (3.18) through ctypes (cached_library).
"""

from __future__ import annotations

import hashlib
import shutil
import subprocess
from pathlib import Path

import casadi as ca

from ..native_fmu import casadi_c
from .model import ND, NU, NX, model

PLANT_STEM = "tl_plant_gen"
LIB_STEM = "tl_plant"


def functions() -> list[ca.Function]:
    """The right-hand side, one RK4 substep and the diagnostic outputs, with CSE applied."""
    m = model()
    rhs = ca.Function("tl_plant_rhs", [m.x, m.u, m.d, m.p], [ca.cse(m.xdot)], ["x", "u", "d", "p"], ["xdot"])
    out = ca.Function("tl_plant_out", [m.x, m.p], [ca.cse(m.diagnostics)], ["x", "p"], ["y"])
    x, u, d = ca.MX.sym("x", NX), ca.MX.sym("u", NU), ca.MX.sym("d", ND)
    p, h = ca.MX.sym("p", m.p.numel()), ca.MX.sym("h")
    k1 = rhs(x, u, d, p)
    k2 = rhs(x + h / 2 * k1, u, d, p)
    k3 = rhs(x + h / 2 * k2, u, d, p)
    k4 = rhs(x + h * k3, u, d, p)
    rk4 = ca.Function("tl_plant_rk4", [x, u, d, p, h], [x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)])
    return [rhs, rk4, out]


def plant_sources(directory: Path) -> list[Path]:
    """tl_plant_gen.c/.h and its sizes header (with the model's dimensions) for the plant FMU."""
    _, rk4, out = functions()
    m = model()
    dims = {"TL_PLANT_NX": NX, "TL_PLANT_NP": m.p.numel(), "TL_PLANT_NY": out.size1_out(0)}
    return casadi_c.generate([rk4, out], directory, PLANT_STEM, dims)


def feedforward_function() -> ca.Function:
    """(3.18) u_tr = L_in^+ (M qdd + (C + L_fr) qd + g) at the reference state, for the controller FMU."""
    m = model()
    x, qdd = ca.SX.sym("x", NX), ca.SX.sym("qdd", NX // 2)
    M, Cqd, g, L_in, L_fr, _ = m.f_terms(x, m.p)
    rhs = M @ qdd + Cqd + L_fr @ x[NX // 2:] + g
    u = ca.solve(L_in.T @ L_in, L_in.T @ rhs)  # least squares: L_in has full column rank
    return ca.Function("tl_feedforward", [x, qdd, m.p], [ca.cse(u)], ["x", "qdd", "p"], ["u"])


def compile_library(directory: Path) -> Path:
    """The controller's shared library (the feedforward), compiled into directory."""
    sources = casadi_c.generate([feedforward_function()], directory, LIB_STEM)
    compiler = shutil.which("cc") or shutil.which("gcc")
    if compiler is None:
        raise RuntimeError("building the FMUs needs a C compiler (cc or gcc) on PATH")
    lib = directory / f"{LIB_STEM}.so"
    cmd = [compiler, "-O2", "-fPIC", "-shared", "-o", str(lib), str(sources[0]), "-lm"]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError(f"compiling the plant library failed: {proc.stderr.strip().splitlines()[-1:]}")
    return lib


def library_digest() -> str:
    """Identity of the compiled library: the model sources and the CasADi version."""
    here = Path(__file__).parent
    h = hashlib.sha256(ca.__version__.encode())
    for f in sorted(here.glob("*.py")) + [Path(casadi_c.__file__)]:
        h.update(f.name.encode() + f.read_bytes())
    return h.hexdigest()[:16]


def cached_library(root: Path) -> Path:
    """The compiled library in root/lib-<digest>/, compiled once and shared by the FMU builds."""
    folder = Path(root) / f"lib-{library_digest()}"
    lib = folder / f"{LIB_STEM}.so"
    if not lib.exists():
        tmp = folder.with_name(folder.name + ".partial")
        shutil.rmtree(tmp, ignore_errors=True)
        compile_library(tmp)
        shutil.rmtree(folder, ignore_errors=True)
        tmp.replace(folder)
    return lib

"""Generate and compile the plant's C code with CasADi (build time only).

The FMU runs this compiled library through ctypes (see native.py), so at run time the
plant needs neither CasADi nor a compiler. One call advances a whole communication
step: a small C driver loops the RK4 substeps and stops at the first non-finite state.
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import casadi as ca

from .model import ND, NU, NX, model

LIB_STEM = "tl_plant"

_DRIVER = r"""
/* Loop driver around the CasADi-generated RK4 substep: one call per communication step. */
#include <math.h>
#include "tl_plant.h"

#define SZ_ARG {sz_arg}
#define SZ_RES {sz_res}
#define SZ_IW {sz_iw}
#define SZ_W {sz_w}

/* Advances x by n substeps of h and writes the outputs y of the new state. On success
   returns 0; if the generated code fails returns -1, and if substep k leaves a non-finite
   state returns k > 0: then x and y are left untouched. x may not alias the other inputs. */
int tl_plant_outputs(const double* x, const double* p, double* y);
int tl_plant_advance(const double* u, const double* d, const double* p, double h, int n,
                     double* x, double* y) {{
  const double* arg[SZ_ARG + 1];
  double* res[SZ_RES + 1];
  casadi_int iw[SZ_IW + 1];
  double w[SZ_W + 1];
  double cur[{nx}], next[{nx}];
  int i, k;
  for (i = 0; i < {nx}; ++i) cur[i] = x[i];
  for (k = 0; k < n; ++k) {{
    arg[0] = cur; arg[1] = u; arg[2] = d; arg[3] = p; arg[4] = &h;
    res[0] = next;
    if (tl_plant_rk4(arg, res, iw, w, 0)) return -1;
    for (i = 0; i < {nx}; ++i) if (!isfinite(next[i])) return k + 1;
    for (i = 0; i < {nx}; ++i) cur[i] = next[i];
  }}
  for (i = 0; i < {nx}; ++i) x[i] = cur[i];
  return tl_plant_outputs(x, p, y) ? -1 : 0;
}}

int tl_plant_outputs(const double* x, const double* p, double* y) {{
  const double* arg[{out_arg} + 1];
  double* res[{out_res} + 1];
  casadi_int iw[{out_iw} + 1];
  double w[{out_w} + 1];
  arg[0] = x; arg[1] = p; res[0] = y;
  return tl_plant_out(arg, res, iw, w, 0);
}}

int tl_plant_xdot(const double* x, const double* u, const double* d, const double* p, double* xdot) {{
  const double* arg[{rhs_arg} + 1];
  double* res[{rhs_res} + 1];
  casadi_int iw[{rhs_iw} + 1];
  double w[{rhs_w} + 1];
  arg[0] = x; arg[1] = u; arg[2] = d; arg[3] = p; res[0] = xdot;
  return tl_plant_rhs(arg, res, iw, w, 0);
}}
"""


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


def feedforward_function() -> ca.Function:
    """(3.18) u_tr = L_in^+ (M qdd + (C + L_fr) qd + g) at the reference state, for the controller FMU."""
    m = model()
    x, qdd = ca.SX.sym("x", NX), ca.SX.sym("qdd", NX // 2)
    M, Cqd, g, L_in, L_fr, _ = m.f_terms(x, m.p)
    rhs = M @ qdd + Cqd + L_fr @ x[NX // 2:] + g
    u = ca.solve(L_in.T @ L_in, L_in.T @ rhs)  # least squares: L_in has full column rank
    return ca.Function("tl_feedforward", [x, qdd, m.p], [ca.cse(u)], ["x", "qdd", "p"], ["u"])


def extra_functions() -> list[ca.Function]:
    """Functions the other FMUs call from the same library: the measurement model and the feedforward."""
    from ..sensor_fmu.measurement import pi_codegen_function

    return [pi_codegen_function(), feedforward_function()]


def generate(directory: Path) -> list[Path]:
    """Write tl_plant.c, tl_plant.h and the driver into directory; return the C sources."""
    directory.mkdir(parents=True, exist_ok=True)
    rhs, rk4, out = functions()
    cg = ca.CodeGenerator(f"{LIB_STEM}.c", {"with_header": True})
    for f in (rhs, rk4, out, *extra_functions()):
        cg.add(f)
    cg.generate(str(directory) + "/")
    sizes = dict(sz_arg=rk4.sz_arg(), sz_res=rk4.sz_res(), sz_iw=rk4.sz_iw(), sz_w=rk4.sz_w(), nx=NX)
    sizes.update(out_arg=out.sz_arg(), out_res=out.sz_res(), out_iw=out.sz_iw(), out_w=out.sz_w())
    sizes.update(rhs_arg=rhs.sz_arg(), rhs_res=rhs.sz_res(), rhs_iw=rhs.sz_iw(), rhs_w=rhs.sz_w())
    driver = directory / f"{LIB_STEM}_driver.c"
    driver.write_text(_DRIVER.format(**sizes))
    return [directory / f"{LIB_STEM}.c", driver]


def compile_library(directory: Path) -> Path:
    """Generate the C code and compile it into a shared library in directory."""
    sources = generate(directory)
    compiler = shutil.which("cc") or shutil.which("gcc")
    if compiler is None:
        raise RuntimeError("building the plant FMU needs a C compiler (cc or gcc) on PATH")
    lib = directory / f"{LIB_STEM}.so"
    cmd = [compiler, "-O3", "-fPIC", "-shared", "-o", str(lib), *map(str, sources), "-lm"]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError(f"compiling the plant library failed: {proc.stderr.strip().splitlines()[-1:]}")
    return lib


def library_digest() -> str:
    """Identity of the compiled library: the model and measurement sources and the CasADi version."""
    import hashlib

    here = Path(__file__).parent
    h = hashlib.sha256(ca.__version__.encode())
    for f in sorted(here.glob("*.py")) + [here.parent / "sensor_fmu" / "measurement.py"]:
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

"""Generate the plant's C code with CasADi (build time only): the one source of the compiled model.

The native plant FMU compiles tl_plant_gen.c (one RK4 substep and the diagnostic outputs) into
its binary; the controller FMU compiles the feedforward (3.18) into its own.
"""

from __future__ import annotations

from pathlib import Path

import casadi as ca

from ..native_fmu import casadi_c
from .model import ND, NU, NX, model

PLANT_STEM = "tl_plant_gen"


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

"""Pure H-infinity and mixed H2/H-infinity state feedback with LMI pole regions (thesis Sec. 3.4).

Solved with cvxpy + SDPA (Clarabel as fallback, see sdp_solver.py) in Bryson-scaled coordinates (x~ = Omega_chi^1/2 x,
u~ = Omega_u^1/2 u): there H_z = [I; 0] and D_zu = [0; I], and the problem is well
conditioned (on the raw 24-state LMIs Clarabel fails: docs/controller.md). Regions: Re(z) > eps (3.43)
and |z| < varpi (3.45), with the common X = T1 = T2 of Sec. 3.4.4. The returned gain is
checked on its own (poles in both regions, H-infinity norm by a frequency sweep, H2 norm by
a Lyapunov equation), never trusted from the solver status alone.
"""

from __future__ import annotations

import cvxpy as cp
import numpy as np

from . import sdp_solver
from .error_dynamics import DesignError, ErrorDynamics
from .lmi_check import EPS_REGION, VARPI_REGION, LMIPoint, LMIResult, build_lmis, checked_gain, closed_loop_norms, h2_bound, scaled
from .weights import check_weight

__all__ = ["EPS_REGION", "VARPI_REGION", "MARGIN", "LMIPoint", "LMIResult", "synthesize"]
MARGIN = 1e-4  # strictness of every LMI (scaled units): solver-tolerance slack must not void the bounds


def _iteration_reporter(progress, every: float = 2.0):
    """SDPA's iterations as one progress line every few seconds (not one per iteration)."""
    last = [-every]

    def report(iteration: int, mu: float, seconds: float):
        if seconds - last[0] >= every:
            last[0] = seconds
            progress(f"  SDPA iteration {iteration} (usually 25-35), duality measure {mu:.1e}, {seconds:.0f} s")
    return report if progress is not None else None


def synthesize(sys: ErrorDynamics, Q: np.ndarray, R: np.ndarray, *, gamma_sq: float | None = None,
               eps: float = EPS_REGION, varpi: float = VARPI_REGION, Dzd: np.ndarray | None = None,
               progress=None) -> LMIResult:
    """gamma_sq None: pure H-infinity with regions (min gamma~). Else mixed H2/H-infinity with gamma~ prescribed.

    progress(str), if given, receives a line every few seconds while SDPA iterates."""
    n, m = sys.B.shape
    Q = check_weight(Q, n, "Omega_chi", definite=True)
    R = check_weight(R, m, "Omega_u", definite=True)
    if not (0.0 <= eps < varpi <= 1.0):
        raise DesignError(f"LMI regions need 0 <= eps < varpi <= 1, got eps={eps}, varpi={varpi}: the region is empty")
    nd = sys.F.shape[1]
    nz = n + m
    Dzd = np.zeros((nz, nd)) if Dzd is None else np.asarray(Dzd, dtype=float)
    if Dzd.shape != (nz, nd):
        raise DesignError(f"D_zd must be {nz}x{nd}, got {Dzd.shape}")
    A, B, F, S, Rh, Rhi, Hz, Dzu = scaled(sys, Q, R)

    X = cp.Variable((n, n), symmetric=True)
    P = cp.Variable((n, n), symmetric=True)
    Y = cp.Variable((m, n))
    g = cp.Variable() if gamma_sq is None else gamma_sq
    N = None if gamma_sq is None else cp.Variable((nz, nz), symmetric=True)
    lmis = build_lmis(cp.bmat, A, B, F, Hz, Dzu, Dzd, X, P, Y, N, g, eps, varpi)
    objective = cp.Minimize(g) if gamma_sq is None else cp.Minimize(cp.trace(N))
    # (3.27) is a principal submatrix of (3.39) with the common X, P: implied, so only checked afterwards
    cons = [expr >> MARGIN * np.eye(expr.shape[0]) for name, expr in lmis.items() if name != "H2 state (3.27)"]
    problem = cp.Problem(objective, cons)
    solvers = ["SDPA", "Clarabel"] if sdp_solver.sdpa_available() else ["Clarabel"]
    failures = []
    for solver in solvers:
        last = solver == solvers[-1]
        try:
            solved = (sdp_solver.solve_sdpa(problem, _iteration_reporter(progress)) if solver == "SDPA"
                      else sdp_solver.solve_clarabel(problem))
        except sdp_solver.SolverFailed as err:
            failures.append(str(err))
            if last:
                raise DesignError("the LMI solver failed: " + "; ".join(failures)) from None
            if progress is not None:
                progress(f"  {err}; solving again with {solvers[-1]}")
            continue
        if solved.status in sdp_solver.INFEASIBLE or X.value is None or Y.value is None:
            what = ("the pole regions and the H-infinity LMI" if gamma_sq is None
                    else f"the pole regions with the prescribed H-infinity bound gamma~ = {gamma_sq:g}")
            failure = f"the LMIs are infeasible: no gain satisfies {what} (solver status: {solved.status})"
            if solved.status in sdp_solver.INFEASIBLE or last:
                raise DesignError(failure)
            failures.append(f"{solver}: {failure}")
            continue
        point = LMIPoint(X.value, P.value, Y.value, None if N is None else N.value,
                         float(g.value) if gamma_sq is None else float(gamma_sq))
        try:
            K, poles, lmi_min_eig = checked_gain(sys, Q, R, point, Dzd, eps, varpi, f"status {solved.status}")
            break
        except DesignError as err:
            if last:
                raise
            failures.append(f"{solver}: {err}")
            if progress is not None:
                progress(f"  {solver}'s point was refused ({err}); solving again with {solvers[-1]}")
    hinf_norm, h2_norm = closed_loop_norms(sys.A, sys.B, sys.F, K, Hz @ S, Dzu @ Rh, Dzd)
    return LMIResult(K, float(np.sqrt(point.gamma_sq)), h2_bound(point), hinf_norm, h2_norm, poles, solved.status,
                     solved.seconds, solved.solver, solved.iterations, lmi_min_eig, point, solved.summary)



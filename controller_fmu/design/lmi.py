"""Pure H-infinity and mixed H2/H-infinity state feedback with LMI pole regions (thesis Sec. 3.4).

Solved with cvxpy + SDPA (Clarabel as fallback, see sdp_solver.py) in Bryson-scaled coordinates (x~ = Omega_chi^1/2 x,
u~ = Omega_u^1/2 u): there H_z = [I; 0] and D_zu = [0; I], and the problem is well
conditioned (on the raw 24-state LMIs Clarabel fails: docs/controller.md). Regions: Re(z) > eps (3.43)
and |z| < varpi (3.45), with the common X = T1 = T2 of Sec. 3.4.4. The returned gain is
checked on its own (poles in both regions, H-infinity norm by a frequency sweep, H2 norm by
a Lyapunov equation), never trusted from the solver status alone.
"""

from __future__ import annotations

from dataclasses import dataclass

import cvxpy as cp
import numpy as np
from scipy.linalg import solve_discrete_lyapunov, sqrtm

from . import sdp_solver
from .error_dynamics import DesignError, ErrorDynamics
from .weights import check_weight

EPS_REGION = 0.55  # Re(z) > eps
VARPI_REGION = 0.99402  # |z| < varpi
MARGIN = 1e-4  # strictness of every LMI (scaled units): solver-tolerance slack must not void the bounds


@dataclass(frozen=True)
class LMIResult:
    K: np.ndarray
    gamma_bound: float  # sqrt of the optimal gamma~ (H-infinity bound)
    h2_bound: float | None  # sqrt(trace N), mixed design only
    hinf_norm: float  # measured on the closed loop
    h2_norm: float  # measured on the closed loop
    poles: np.ndarray
    status: str
    seconds: float
    solver: str
    iterations: int
    lmi_min_eig: dict  # smallest eigenvalue of every LMI evaluated at the returned point (must be > 0)


def _iteration_reporter(progress, every: float = 2.0):
    """SDPA's iterations as one progress line every few seconds (not one per iteration)."""
    last = [-every]

    def report(iteration: int, mu: float, seconds: float):
        if seconds - last[0] >= every:
            last[0] = seconds
            progress(f"  SDPA iteration {iteration} (usually 25-35), duality measure {mu:.1e}, {seconds:.0f} s")
    return report if progress is not None else None


def _closed_loop_norms(A, B, F, K, Hz, Dzu, Dzd) -> tuple[float, float]:
    """H-infinity norm (frequency sweep, refined) and H2 norm of d -> z for u = -K chi."""
    Acl, Hcl = A - B @ K, Hz - Dzu @ K
    n = A.shape[0]

    def sigma(w):
        G = Hcl @ np.linalg.solve(np.exp(1j * w) * np.eye(n) - Acl, F) + Dzd
        return np.linalg.svd(G, compute_uv=False)[0]

    grid = np.concatenate([np.geomspace(1e-6, np.pi, 3000)])
    values = np.array([sigma(w) for w in grid])
    i = int(np.argmax(values))
    lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, len(grid) - 1)]
    for _ in range(60):  # golden-section refinement around the peak
        a, b = lo + 0.382 * (hi - lo), lo + 0.618 * (hi - lo)
        if sigma(a) > sigma(b):
            hi = b
        else:
            lo = a
    hinf = max(values.max(), sigma(0.5 * (lo + hi)), sigma(0.0))
    Wc = solve_discrete_lyapunov(Acl, F @ F.T)
    h2 = float(np.sqrt(np.trace(Hcl @ Wc @ Hcl.T)))
    return float(hinf), h2


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
    S, Rh = np.real(sqrtm(Q)), np.real(sqrtm(R))
    Si, Rhi = np.linalg.inv(S), np.linalg.inv(Rh)
    A, B, F = S @ sys.A @ Si, S @ sys.B @ Rhi, S @ sys.F  # scaled plant
    Hz = np.vstack([np.eye(n), np.zeros((m, n))])
    Dzu = np.vstack([np.zeros((n, m)), np.eye(m)])

    X = cp.Variable((n, n), symmetric=True)
    P = cp.Variable((n, n), symmetric=True)
    Y = cp.Variable((m, n))
    AXBY = A @ X + B @ Y
    W = 2 * X - P
    margin = MARGIN
    lmis = {"X > 0": X, "Re(z) > eps (3.43)": AXBY + AXBY.T - 2 * eps * X,
            "|z| < varpi (3.45)": cp.bmat([[varpi * X, AXBY], [AXBY.T, varpi * X]])}
    g = cp.Variable() if gamma_sq is None else gamma_sq
    HXDY = Hz @ X + Dzu @ Y
    hinf = cp.bmat([
        [P, AXBY, F, np.zeros((n, nz))],
        [AXBY.T, W, np.zeros((n, nd)), HXDY.T],
        [F.T, np.zeros((nd, n)), np.eye(nd), Dzd.T],
        [np.zeros((nz, n)), HXDY, Dzd, g * np.eye(nz)],
    ])
    lmis["H-infinity (3.39)"] = 0.5 * (hinf + hinf.T)
    if gamma_sq is None:
        objective = cp.Minimize(g)
        N = None
    else:
        N = cp.Variable((nz, nz), symmetric=True)
        h2a = cp.bmat([[N, HXDY], [HXDY.T, W]])
        h2b = cp.bmat([
            [P, AXBY, F],
            [AXBY.T, W, np.zeros((n, nd))],
            [F.T, np.zeros((nd, n)), np.eye(nd)],
        ])
        lmis["H2 output (3.28)"] = 0.5 * (h2a + h2a.T)
        objective = cp.Minimize(cp.trace(N))
    cons = [expr >> margin * np.eye(expr.shape[0]) for expr in lmis.values()]
    if gamma_sq is not None:
        # (3.27) is a principal submatrix of (3.39) with the common X, P: implied, so only checked afterwards
        lmis["H2 state (3.27)"] = 0.5 * (h2b + h2b.T)
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
        try:
            K, poles, lmi_min_eig = _checked_gain(sys, lmis, X.value, Y.value, S, Rhi, eps, varpi, solved.status)
            break
        except DesignError as err:
            if last:
                raise
            failures.append(f"{solver}: {err}")
            if progress is not None:
                progress(f"  {solver}'s point was refused ({err}); solving again with {solvers[-1]}")
    hinf_norm, h2_norm = _closed_loop_norms(sys.A, sys.B, sys.F, K, Hz @ S, Dzu @ Rh, Dzd)
    gamma_val = float(g.value) if gamma_sq is None else float(gamma_sq)
    h2_bound = float(np.sqrt(np.trace(N.value))) if N is not None else None
    return LMIResult(K, float(np.sqrt(gamma_val)), h2_bound, hinf_norm, h2_norm, poles, solved.status, solved.seconds,
                     solved.solver, solved.iterations, lmi_min_eig)


def _checked_gain(sys, lmis, Xv, Yv, S, Rhi, eps, varpi, status):
    """The physical gain at the solver's point, refused unless every LMI holds there and the poles are in the regions."""
    lmi_min_eig = {name: float(np.linalg.eigvalsh(expr.value)[0]) for name, expr in lmis.items()}
    broken = {name: v for name, v in lmi_min_eig.items() if not v > 0}
    if broken:
        raise DesignError(f"the solver's point (status {status}) violates the LMIs: "
                          + ", ".join(f"{name} min eigenvalue {v:.2e}" for name, v in broken.items()))
    K = Rhi @ (-Yv @ np.linalg.inv(Xv)) @ S  # back to physical units
    poles = np.linalg.eigvals(sys.A - sys.B @ K)
    if not (np.all(poles.real > eps - 1e-6) and np.all(np.abs(poles) < varpi + 1e-6)):
        raise DesignError(
            f"the solver returned a gain whose poles leave the regions (status {status}; "
            f"min Re {poles.real.min():.5f} vs eps {eps}, max |z| {np.abs(poles).max():.6f} vs varpi {varpi})"
        )
    return K, poles, lmi_min_eig

"""The inner loop of each UAV (Sec. B.3.3): D-stable H-infinity state feedback on the polytopic model (B.12).

Continuous-time LMIs with one Q and one Y for every vertex (quadratic stability):
(B.18) the H-infinity bound gamma (minimized), (B.19) Re(s) < -lambda, (B.20) the disc centred at
(c, 0) of radius r, (B.21) the cone |Im s| < tan(mu) |Re s|; K = Y Q^-1 and delta_u = K chi (the
thesis's delta_u = -K chi with K = -Y Q^-1). The polytope: the thrusters' fixed inclination beta
from 0 to pi/18 (Sec. B.2.1), each vertex linearized at its own hover trim with the integral states
of (A.5) (error_dynamics.augmented_continuous). Weights of Sec. B.4: H_z'H_z = Omega_chi,
D_zu'D_zu = Omega_u of (A.5); D_zd = 0 (chosen: the thesis's trial-and-error D_zd is for its 8
disturbance inputs, this model has the 3 external forces). Solved in Bryson-scaled coordinates
(a similarity: poles and gamma unchanged); the gain is accepted only if every vertex's closed-loop
poles lie in the three regions and its H-infinity norm, measured by a frequency sweep, is below gamma.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import cvxpy as cp
import numpy as np
from scipy.linalg import sqrtm

from ..controller_fmu.design import sdp_solver
from ..controller_fmu.design.error_dynamics import DesignError, augmented_continuous
from ..controller_fmu.design.weights import omega_chi, omega_u
from ..plant_fmu.linearize import linearize
from ..plant_fmu.trim import hover_trim
from ..plant_fmu.vehicles import VEHICLES

LAMBDA, DISC_C, DISC_R, CONE_MU = 2.2, 0.0, 100.0, math.pi / 10  # Table B.1
BETAS = (0.0, math.pi / 18)  # the polytope's vertices (Sec. B.2.1)
THESIS_GAMMA = 113.4739
MARGIN = 1e-6


@dataclass(frozen=True)
class DStableDesign:
    K: np.ndarray  # 4 x 20: delta_u = -K chi (the thesis's sign)
    gamma: float  # the LMI bound
    hinf: list[float]  # measured per vertex
    poles: list[np.ndarray]  # closed loop per vertex
    trim_x: np.ndarray  # the nominal vertex's
    trim_u: np.ndarray
    seconds: float
    solver: str
    status: str


def vertices(betas=BETAS):
    """(A, B, F) of (B.11) at each beta, with the trim and parameters of the first (nominal) one."""
    uav = VEHICLES["uav"]
    out = []
    for beta in betas:
        p = np.array(uav.default_parameters(), dtype=float)
        p[uav.parameters.index("beta")] = beta
        trim = hover_trim(p, vehicle="uav")
        lin = linearize(trim.x, trim.u, p, vehicle="uav")
        A, B, F = augmented_continuous(lin.A, lin.B, lin.F)
        out.append((A, B, F, trim))
    return out


def in_regions(poles: np.ndarray, tol: float = 1e-6) -> bool:
    return bool(np.all(poles.real < -LAMBDA + tol) and np.all(np.abs(poles - DISC_C) < DISC_R + tol)
                and np.all(np.abs(poles.imag) <= math.tan(CONE_MU) * np.abs(poles.real) + tol))


def hinf_norm(A, B, F, K, Hz, Dzu) -> float:
    """sup over omega of the largest singular value of d -> z (continuous time), by a sweep refined at its peak."""
    Acl, Hcl = A - B @ K, Hz - Dzu @ K
    n = A.shape[0]

    def sigma(w):
        return np.linalg.svd(Hcl @ np.linalg.solve(1j * w * np.eye(n) - Acl, F), compute_uv=False)[0]

    grid = np.concatenate([[0.0], np.geomspace(1e-4, 1e4, 4000)])
    values = np.array([sigma(w) for w in grid])
    i = int(np.argmax(values))
    lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, len(grid) - 1)]
    for _ in range(60):
        a, b = lo + 0.382 * (hi - lo), lo + 0.618 * (hi - lo)
        if sigma(a) > sigma(b):
            hi = b
        else:
            lo = a
    return float(max(values.max(), sigma(0.5 * (lo + hi))))


def design(progress=None) -> DStableDesign:
    start = time.perf_counter()
    verts = vertices()
    trim = verts[0][3]
    Q_w, R_w = omega_chi("uav"), omega_u(trim.u)
    S, Rh = np.real(sqrtm(Q_w)), np.real(sqrtm(R_w))
    Si, Rhi = np.linalg.inv(S), np.linalg.inv(Rh)
    n, m = verts[0][1].shape
    nd = verts[0][2].shape[1]
    nz = n + m
    Hz = np.vstack([np.eye(n), np.zeros((m, n))])  # scaled: [Omega_chi^1/2; 0] S^-1
    Dzu = np.vstack([np.zeros((n, m)), np.eye(m)])  # scaled: [0; Omega_u^1/2] Omega_u^-1/2
    Q = cp.Variable((n, n), symmetric=True)
    Y = cp.Variable((m, n))
    gamma = cp.Variable()
    lmis = [Q >> MARGIN * np.eye(n)]
    s, c = math.sin(CONE_MU), math.cos(CONE_MU)
    for A, B, F, _ in verts:
        A, B, F = S @ A @ Si, S @ B @ Rhi, S @ F
        U = A @ Q + B @ Y
        HQ = Hz @ Q + Dzu @ Y
        b18 = cp.bmat([[U + U.T, F, HQ.T], [F.T, -gamma * np.eye(nd), np.zeros((nd, nz))],
                       [HQ, np.zeros((nz, nd)), -gamma * np.eye(nz)]])
        b20 = cp.bmat([[-DISC_R * Q, U - DISC_C * Q], [(U - DISC_C * Q).T, -DISC_R * Q]])
        b21 = cp.bmat([[s * (U + U.T), c * (U - U.T)], [c * (U.T - U), s * (U + U.T)]])
        for block in (b18, U + U.T + 2 * LAMBDA * Q, b20, b21):
            sym = 0.5 * (block + block.T)
            lmis.append(-sym >> MARGIN * np.eye(sym.shape[0]))
    problem = cp.Problem(cp.Minimize(gamma), lmis)
    if progress is not None:
        progress("synthesizing the D-stable H-infinity design of Appendix B (2 vertices, LMIs (B.18)-(B.21)) ...")
    try:
        solved = (sdp_solver.solve_sdpa(problem) if sdp_solver.sdpa_available() else sdp_solver.solve_clarabel(problem))
    except sdp_solver.SolverFailed as err:
        raise DesignError(f"the D-stable H-infinity LMIs could not be solved: {err}") from None
    if Q.value is None or solved.status in sdp_solver.INFEASIBLE:
        raise DesignError(f"the D-stable H-infinity LMIs are infeasible (solver status {solved.status})")
    K = -(Rhi @ (Y.value @ np.linalg.inv(Q.value)) @ S)  # delta_u = -K chi in physical units
    poles, norms = [], []
    for A, B, F, _ in verts:
        p = np.linalg.eigvals(A - B @ K)
        if not in_regions(p):
            raise DesignError(f"the returned gain puts poles outside the regions (max Re {p.real.max():.4f}, "
                              f"max |s| {np.abs(p).max():.2f})")
        poles.append(p)
        norms.append(hinf_norm(A, B, F, K, np.vstack([S, np.zeros((m, n))]), np.vstack([np.zeros((n, m)), Rh])))
    return DStableDesign(K, float(gamma.value), norms, poles, trim.x, trim.u, time.perf_counter() - start,
                         solved.solver, solved.status)

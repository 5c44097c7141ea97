"""Checking an LMI design at a point, with numbers only: the LMIs of Sec. 3.4 evaluated at (X, P, Y, N, gamma~), the
gain they give and its poles, the closed-loop norms. The synthesis (lmi.py) checks the solver's point with it, and a
stored design (a cached or shipped one) is checked with it again before use, in milliseconds and without cvxpy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import solve_discrete_lyapunov, sqrtm

from .error_dynamics import DesignError, ErrorDynamics
from .weights import check_weight

EPS_REGION = 0.55  # Re(z) > eps
VARPI_REGION = 0.99402  # |z| < varpi


@dataclass(frozen=True)
class LMIPoint:
    """The solver's point in Bryson-scaled coordinates: what the LMIs are checked at, and what a stored design keeps
    so that anyone can check it again without solving (verify)."""

    X: np.ndarray
    P: np.ndarray
    Y: np.ndarray
    N: np.ndarray | None  # mixed design only
    gamma_sq: float  # the H-infinity bound gamma~: optimal (pure H-infinity) or prescribed (mixed)

    def to_json(self) -> dict:
        out = {"X": self.X.tolist(), "P": self.P.tolist(), "Y": self.Y.tolist(), "gamma_sq": self.gamma_sq}
        if self.N is not None:
            out["N"] = self.N.tolist()
        return out

    @classmethod
    def from_json(cls, data: dict) -> LMIPoint:
        try:
            arrays = {k: np.array(data[k], dtype=float) for k in ("X", "P", "Y")}
            N = np.array(data["N"], dtype=float) if data.get("N") is not None else None
            return cls(**arrays, N=N, gamma_sq=float(data["gamma_sq"]))
        except (KeyError, TypeError, ValueError) as err:
            raise DesignError(f"the stored LMI point is malformed ({err})") from None


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
    point: LMIPoint | None = None
    solver_summary: dict | None = None  # what the solver said of its point (SDPA's phase, gap, feasibility errors)


def closed_loop_norms(A, B, F, K, Hz, Dzu, Dzd) -> tuple[float, float]:
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


def scaled(sys: ErrorDynamics, Q: np.ndarray, R: np.ndarray):
    """The plant in Bryson-scaled coordinates, where H_z = [I; 0] and D_zu = [0; I]; the scalings to go back."""
    n, m = sys.B.shape
    S, Rh = np.real(sqrtm(Q)), np.real(sqrtm(R))
    Si, Rhi = np.linalg.inv(S), np.linalg.inv(Rh)
    Hz = np.vstack([np.eye(n), np.zeros((m, n))])
    Dzu = np.vstack([np.zeros((n, m)), np.eye(m)])
    return S @ sys.A @ Si, S @ sys.B @ Rhi, S @ sys.F, S, Rh, Rhi, Hz, Dzu


def build_lmis(bmat, A, B, F, Hz, Dzu, Dzd, X, P, Y, N, g, eps, varpi) -> dict:
    """Every LMI of the design, each required > 0: built with cvxpy's bmat on variables to solve, with numpy's block
    on numbers to check a point. N None: pure H-infinity (no H2 LMIs)."""
    n, nd, nz = A.shape[0], F.shape[1], Hz.shape[0]
    AXBY = A @ X + B @ Y
    W = 2 * X - P
    HXDY = Hz @ X + Dzu @ Y
    lmis = {"X > 0": X, "Re(z) > eps (3.43)": AXBY + AXBY.T - 2 * eps * X,
            "|z| < varpi (3.45)": bmat([[varpi * X, AXBY], [AXBY.T, varpi * X]])}
    hinf = bmat([
        [P, AXBY, F, np.zeros((n, nz))],
        [AXBY.T, W, np.zeros((n, nd)), HXDY.T],
        [F.T, np.zeros((nd, n)), np.eye(nd), Dzd.T],
        [np.zeros((nz, n)), HXDY, Dzd, g * np.eye(nz)],
    ])
    lmis["H-infinity (3.39)"] = 0.5 * (hinf + hinf.T)
    if N is not None:
        h2a = bmat([[N, HXDY], [HXDY.T, W]])
        h2b = bmat([
            [P, AXBY, F],
            [AXBY.T, W, np.zeros((n, nd))],
            [F.T, np.zeros((nd, n)), np.eye(nd)],
        ])
        lmis["H2 output (3.28)"] = 0.5 * (h2a + h2a.T)
        lmis["H2 state (3.27)"] = 0.5 * (h2b + h2b.T)
    return lmis


def h2_bound(point: LMIPoint) -> float | None:
    return float(np.sqrt(np.trace(point.N))) if point.N is not None else None


def verify(sys: ErrorDynamics, Q: np.ndarray, R: np.ndarray, point: LMIPoint, *, mixed: bool, eps: float = EPS_REGION,
           varpi: float = VARPI_REGION, Dzd: np.ndarray | None = None, measure_norms: bool = True) -> LMIResult:
    """A stored point checked as a freshly solved one is, on this model: every LMI's smallest eigenvalue at the point
    (> 0), the gain it gives, that gain's poles in both regions. Nothing of the point is trusted; DesignError if
    anything fails. mixed: the point must carry N (the H2 LMIs). A few milliseconds (the norms, measured by a
    frequency sweep, take ~0.1 s more: measure_norms=False skips them)."""
    n, m = sys.B.shape
    Q = check_weight(Q, n, "Omega_chi", definite=True)
    R = check_weight(R, m, "Omega_u", definite=True)
    nz, nd = n + m, sys.F.shape[1]
    Dzd = np.zeros((nz, nd)) if Dzd is None else np.asarray(Dzd, dtype=float)
    shapes = {"X": (point.X.shape, (n, n)), "P": (point.P.shape, (n, n)), "Y": (point.Y.shape, (m, n))}
    if mixed:
        shapes["N"] = (None if point.N is None else point.N.shape, (nz, nz))
    wrong = [f"{k} is {got}, not {want}" for k, (got, want) in shapes.items() if got != want]
    if wrong:
        raise DesignError(f"the stored LMI point does not fit this model: {', '.join(wrong)}")
    if not all(np.isfinite(a).all() for a in (point.X, point.P, point.Y, *(() if point.N is None else (point.N,)))):
        raise DesignError("the stored LMI point has non-finite entries")
    point = point if mixed else LMIPoint(point.X, point.P, point.Y, None, point.gamma_sq)
    K, poles, lmi_min_eig = checked_gain(sys, Q, R, point, Dzd, eps, varpi, "stored point")
    hinf_norm = h2_norm = float("nan")
    if measure_norms:
        hinf_norm, h2_norm = measured_norms(sys, Q, R, K, Dzd)
    return LMIResult(K, float(np.sqrt(point.gamma_sq)), h2_bound(point), hinf_norm, h2_norm, poles, "verified", 0.0,
                     "none (stored point)", 0, lmi_min_eig, point)


def measured_norms(sys: ErrorDynamics, Q: np.ndarray, R: np.ndarray, K: np.ndarray,
                   Dzd: np.ndarray | None = None) -> tuple[float, float]:
    """(H-infinity, H2) norms of d -> z measured on the closed loop of gain K (frequency sweep; Lyapunov equation)."""
    n, m = sys.B.shape
    Dzd = np.zeros((n + m, sys.F.shape[1])) if Dzd is None else np.asarray(Dzd, dtype=float)
    _, _, _, S, Rh, _, Hz, Dzu = scaled(sys, Q, R)
    return closed_loop_norms(sys.A, sys.B, sys.F, K, Hz @ S, Dzu @ Rh, Dzd)


def checked_gain(sys, Q, R, point: LMIPoint, Dzd, eps, varpi, what: str):
    """The physical gain at a point, refused unless every LMI holds there and the poles are in the regions."""
    A, B, F, S, _, Rhi, Hz, Dzu = scaled(sys, Q, R)
    values = build_lmis(np.block, A, B, F, Hz, Dzu, Dzd, point.X, point.P, point.Y, point.N, point.gamma_sq, eps, varpi)
    lmi_min_eig = {name: float(np.linalg.eigvalsh(v)[0]) for name, v in values.items()}
    broken = {name: v for name, v in lmi_min_eig.items() if not v > 0}
    if broken:
        raise DesignError(f"the solver's point ({what}) violates the LMIs: "
                          + ", ".join(f"{name} min eigenvalue {v:.2e}" for name, v in broken.items()))
    K = Rhi @ (-point.Y @ np.linalg.inv(point.X)) @ S  # back to physical units
    poles = np.linalg.eigvals(sys.A - sys.B @ K)
    if not (np.all(poles.real > eps - 1e-6) and np.all(np.abs(poles) < varpi + 1e-6)):
        raise DesignError(
            f"the solver returned a gain whose poles leave the regions ({what}; "
            f"min Re {poles.real.min():.5f} vs eps {eps}, max |z| {np.abs(poles).max():.6f} vs varpi {varpi})"
        )
    return K, poles, lmi_min_eig


def lmi_report(res: LMIResult) -> dict:
    """The figures of merit of an LMI design, as checked at its point."""
    return {
        "spectral_radius": float(np.abs(res.poles).max()),
        "min_real_pole": float(res.poles.real.min()),
        "regions": {"eps": EPS_REGION, "varpi": VARPI_REGION},
        "gamma_bound": res.gamma_bound,
        "hinf_norm": res.hinf_norm,
        "h2_bound": res.h2_bound,
        "h2_norm": res.h2_norm,
        "solver": res.solver,
        "solver_status": res.status,
        "solver_iterations": res.iterations,
        "solver_summary": res.solver_summary,
        "solver_seconds": res.seconds,
        "lmi_min_eig": res.lmi_min_eig,
    }

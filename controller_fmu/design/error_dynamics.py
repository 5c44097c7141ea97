"""Linearized error dynamics at the trim, augmented with integral action (thesis 3.7-3.9).

chi = [dx (20), int(x - x_tr), int(y - y_tr), int(z - z_tr), int(psi - psi_tr)] in R^24 (the UAV
alone, Sec. A.3: dx has 16 entries, chi 20), discretized by zero-order hold at the controller period T_c.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...plant_fmu.linearize import linearize, zoh
from ...plant_fmu.trim import Trim, hover_trim
from ...plant_fmu.vehicles import VEHICLES
from .control_law import REGULATED

NCHI = 24


LOOP_DELAYS = (0, 1, 2)  # ticks of transport delay a design can be made for (a Jacobi master adds 1 or 2: docs/ports.md)


class DesignError(ValueError):
    """A design input or result that cannot give a valid controller; the message says which."""


@dataclass(frozen=True)
class ErrorDynamics:
    """chi_{k+1} = A chi_k + B du_k + F d_k at sampling time T_c, around trim."""

    A: np.ndarray
    B: np.ndarray
    F: np.ndarray
    Tc: float
    trim: Trim
    params: np.ndarray


def augmented_continuous(A_c: np.ndarray, B_c: np.ndarray, F_c: np.ndarray):
    """(3.8): append the integrals of the x, y, z and psi errors."""
    n = A_c.shape[0]
    A = np.zeros((n + 4, n + 4))
    A[:n, :n] = A_c
    for row, idx in enumerate(REGULATED):
        A[n + row, idx] = 1.0
    B = np.vstack([B_c, np.zeros((4, B_c.shape[1]))])
    F = np.vstack([F_c, np.zeros((4, F_c.shape[1]))])
    return A, B, F


def controllability_rank(A: np.ndarray, B: np.ndarray) -> int:
    """Rank of [B AB ... A^(n-1) B], columns scaled to unit norm for numerical robustness."""
    n = A.shape[0]
    blocks, M = [], B
    for _ in range(n):
        blocks.append(M / max(np.linalg.norm(M), 1e-300))
        M = A @ M
    return int(np.linalg.matrix_rank(np.hstack(blocks), tol=1e-10))


def error_dynamics(Tc: float = 0.012, p: np.ndarray | None = None, psi: float = 0.0, vehicle: str = "load") -> ErrorDynamics:
    """ZOH-discretized augmented error dynamics; raise DesignError if not controllable."""
    if not (np.isfinite(Tc) and Tc > 0):
        raise DesignError(f"controller period T_c must be positive and finite, got {Tc!r}")
    p = VEHICLES[vehicle].default_parameters() if p is None else np.asarray(p, dtype=float)
    trim = hover_trim(p, psi=psi, vehicle=vehicle)
    lin = linearize(trim.x, trim.u, p, vehicle=vehicle)
    A_c, B_c, F_c = augmented_continuous(lin.A, lin.B, lin.F)
    A, BF = zoh(A_c, np.hstack([B_c, F_c]), Tc)
    B, F = BF[:, :4], BF[:, 4:]
    rank = controllability_rank(A, B)
    if rank < A.shape[0]:
        raise DesignError(f"the augmented error dynamics are not controllable (rank {rank} < {A.shape[0]})")
    return ErrorDynamics(A, B, F, Tc, trim, p)


def with_loop_delay(sys: ErrorDynamics, d: int) -> ErrorDynamics:
    """The model a delay-aware design is made on: the input reaches the plant d ticks after it is computed.

    State [chi_k; du_{k-d}; ...; du_{k-1}] (oldest first): chi_{k+1} = A chi_k + B du_{k-d}, the chain shifts, and
    the new input du_k enters its last block. The controller knows every block (its own past outputs), so a state
    feedback on this model is realizable; with d = 0 it is the model itself."""
    if d not in LOOP_DELAYS:
        raise DesignError(f"loop delay must be one of {', '.join(map(str, LOOP_DELAYS))} ticks, got {d!r}")
    if d == 0:
        return sys
    n, m = sys.B.shape
    size = n + m * d
    A = np.zeros((size, size))
    A[:n, :n], A[:n, n:n + m] = sys.A, sys.B
    for j in range(d - 1):
        A[n + m * j:n + m * (j + 1), n + m * (j + 1):n + m * (j + 2)] = np.eye(m)
    B = np.zeros((size, m))
    B[size - m:] = np.eye(m)
    F = np.vstack([sys.F, np.zeros((m * d, sys.F.shape[1]))])
    return ErrorDynamics(A, B, F, sys.Tc, sys.trim, sys.params)

"""Linearization of phi(x, u, d) and its zero-order-hold discretization (thesis Sec. 3.2)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm

from .model import model


@dataclass(frozen=True)
class Linearization:
    """x_dot ~ A dx + B du + F d around (x, u, d)."""

    A: np.ndarray
    B: np.ndarray
    F: np.ndarray


def linearize(x, u, p, d=None, vehicle: str = "load") -> Linearization:
    """Exact Jacobians A_c, B_c, F_c by CasADi's automatic differentiation."""
    d = np.zeros(3) if d is None else d
    A, B, F = (np.array(m) for m in model(vehicle).f_jacobians(x, u, d, p))
    return Linearization(A, B, F)


def zoh(A: np.ndarray, B: np.ndarray, T: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact zero-order-hold discretization: expm([[A, B], [0, 0]] T) = [[A_d, B_d], [0, I]]."""
    if not (np.isfinite(T) and T > 0):
        raise ValueError(f"sampling time must be positive and finite, got {T!r}")
    n, m = A.shape[0], B.shape[1]
    block = np.zeros((n + m, n + m))
    block[:n, :n], block[:n, n:] = A, B
    E = expm(block * T)
    return E[:n, :n], E[:n, n:]

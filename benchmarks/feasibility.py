"""The feasibility check's time against a mission's length: 100, 1,000 and 10,000 waypoints.

Each mission is a survey circle flown from rest to rest (3 m radius, the altitude swinging by 0.5 m) with a waypoint every 0.3 s, so its
duration grows with its waypoints (30 s, 300 s, 3,000 s). For each: reading the file through the input layer and the
minimum-jerk solve (scenario_fmu.waypoints, a banded solve), and the feasibility check (master/app/feasibility/trajectory_check.py:
the feedforward at every 12 ms tick, the trim every 0.12 s). Beside them, the dense solve the minimum jerk used before
(a 3n x 3n matrix: 7 GB at 10,000 waypoints, so measured up to 1,000 only).

Run: python benchmarks/feasibility.py   (per-waypoint columns should stay flat: the cost is linear)
"""

from __future__ import annotations

import math
import tempfile
import time
from pathlib import Path

import numpy as np
import scipy.linalg
from tiltload.master.app.feasibility.trajectory_check import check_reference
from tiltload.master.app.loop.inputs import trajectory
from tiltload.scenario_fmu import waypoints

SPACING = 0.3  # s between waypoints


def mission(folder: Path, n: int) -> Path:
    path = folder / f"survey{n}.csv"
    T = (n - 1) * SPACING
    rows = ["t,x,y,z"]
    for i in range(n):
        tau = i * SPACING / T
        w = 2 * math.pi * tau - math.sin(2 * math.pi * tau)  # from rest to rest
        rows.append(f"{i * SPACING:.3f},{3 * math.sin(w):.6f},{3 * (1 - math.cos(w)):.6f},{1 + 0.5 * math.sin(2 * w):.6f}")
    path.write_text("\n".join(rows) + "\n")
    return path


def dense_minimum_jerk(t: np.ndarray, p: np.ndarray) -> None:
    """The former solve: the whole 3n x 3n cost matrix, the free entries' block solved densely (ends at rest)."""
    n = t.size
    G = np.zeros((3 * n, 3 * n))
    for i in range(n - 1):
        T = t[i + 1] - t[i]
        S = np.diag([1, T, T * T, 1, T, T * T])
        idx = np.r_[3 * i:3 * i + 6]
        G[np.ix_(idx, idx)] += S @ waypoints.H_JERK @ S / T**5
    w = np.full(3 * n, np.nan)
    w[0::3], w[[1, 2, -2, -1]] = p, 0.0
    free = np.isnan(w)
    A, b = G[np.ix_(free, free)], -G[np.ix_(free, ~free)] @ w[~free]
    scale = 1 / np.sqrt(np.diag(A))
    scipy.linalg.solve(A * np.outer(scale, scale), b * scale, assume_a="pos")


def main() -> None:
    check_reference({"trajectory": 1}, 1.0)  # CasADi's functions built once, outside the timings
    print("wall-clock seconds (CPU seconds of this process in brackets: the machine may be shared)")
    print(f"{'waypoints':>9} {'duration':>9} {'read+solve':>16} {'check':>18} {'check/waypoint':>15} {'dense solve, before':>26}")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for n in (100, 1_000, 10_000):
            path = mission(folder, n)
            started, cpu = time.perf_counter(), time.process_time()
            ref = trajectory(str(path))
            solved = f"{time.perf_counter() - started:.2f} ({time.process_time() - cpu:.2f})"
            parameters = ref.fmu_parameters(folder)
            started, cpu = time.perf_counter(), time.process_time()
            report = check_reference(parameters, ref.duration)
            checked, checked_cpu = time.perf_counter() - started, time.process_time() - cpu
            assert report.ok, report.problems
            dense = "(7 GB: not run)"
            if n <= 1_000:
                started, cpu = time.perf_counter(), time.process_time()
                for _ in range(4):  # the four axes
                    dense_minimum_jerk(np.arange(n) * SPACING, np.random.default_rng(0).normal(size=n))
                dense = f"{time.perf_counter() - started:.2f} ({time.process_time() - cpu:.2f})"
            print(f"{n:>9} {ref.duration:>8.0f}s {solved:>16} {f'{checked:.2f} ({checked_cpu:.2f})':>18} "
                  f"{checked / n * 1e3:>12.2f} ms {dense:>26}")


if __name__ == "__main__":
    main()

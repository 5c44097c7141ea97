"""Cost per 12 ms step of the ZSE and the LKF, C and Python, tightness of the reductions, and the
controller FMU's doStep per estimator (docs/estimators.md; targets ZSE <= 100 us, LKF <= 10 us, FSI law <= 5 us).

All variants run on the same recorded data: the linearized plant (Sec. 4.3.3) under an LQR on
the true state, process noise uniform in W_bar, measurement noise uniform in V_bar, the
multirate schedule of Table 5.8. The C estimators are compiled from the built controller FMU's
sources/ with its flags (controller_fmu/reference/native_estimators.py). Set OPENBLAS_NUM_THREADS=1: numpy's
idle BLAS threads otherwise spin on the second core and slow both.
Run: python benchmarks/estimators.py [steps]
"""

from __future__ import annotations

import ctypes
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
from scipy.linalg import solve_discrete_are
from tiltload.controller_fmu.design.estimator_setup import augmented_model, lkf_setup, zse_setup
from tiltload.controller_fmu.reference import native_estimators
from tiltload.controller_fmu.reference.lkf import KalmanFilter
from tiltload.controller_fmu.reference.zonotope import REDUCTIONS, reduce_rows
from tiltload.controller_fmu.reference.zse import ZonotopicEstimator
from tiltload.master.app.loop.fmus import build_all

ROOT = Path(__file__).resolve().parents[1]


def schedule(k: int) -> np.ndarray:
    mask = np.ones(16, dtype=bool)
    mask[[0, 1]] = k % 10 == 0  # GPS, 120 ms
    mask[[9, 10, 11]] = k % 2 == 0  # camera, 24 ms
    return mask


def record(model, z, steps, seed=0):
    rng = np.random.default_rng(seed)
    A, B = model.A[:20, :20], model.B[:20]
    P = solve_discrete_are(A, B, np.eye(20), np.eye(4))
    K = np.linalg.solve(B.T @ P @ B + np.eye(4), B.T @ P @ A)
    nu = z.G_x0 @ rng.uniform(-1, 1, 23)
    y0 = z.y_eq + z.H @ nu + np.diag(z.G_v) * rng.uniform(-1, 1, 16)
    data = []
    for _ in range(steps):
        du = -K @ nu[:20]
        nu = model.A @ nu + model.B @ du + np.diag(z.G_w) * rng.uniform(-1, 1, 23)
        data.append((du, z.y_eq + z.H @ nu + np.diag(z.G_v) * rng.uniform(-1, 1, 16), nu))
    return y0, data


def textbook_step(model, z, c, Gt, du, y, idx):
    """Alg. 4.4 as printed: hstack per strip, Combastel by full sort (the first implementation's 4.2 ms)."""
    G = np.hstack([z.G_w, model.A @ Gt.T])
    c = model.A @ c + model.B @ du
    for i in idx:
        rho, sigma = z.H[i], z.G_v[i, i]
        lam = G @ (G.T @ rho) / (rho @ G @ G.T @ rho + sigma**2)
        c = c + lam * (y[i] - z.y_eq[i] - rho @ c)
        G = np.hstack([G - np.outer(lam, rho @ G), sigma * lam[:, None]])
    return c, reduce_rows(G.T, z.r_max, "combastel")


def zse_rows(implementation, make, model, z, y0, data, steps):
    for method in REDUCTIONS:
        est = make(method)
        est.initialize(np.zeros(23), z.G_x0, y0, schedule(0))
        times, full, frob, width, width_xyz, ratio = [], [], [], [], [], 0.0
        for k, (du, y, nu) in enumerate(data, start=1):
            mask = schedule(k)
            t = time.perf_counter()
            est.step(du, y, mask)
            dt = time.perf_counter() - t
            if k > steps // 3:  # steady state: the generator count has reached r_max
                times.append(dt)
                if mask.all():
                    full.append(dt)
                frob.append(est.frobenius())
                width.append(2 * est.hull.mean())
                width_xyz.append(2 * est.hull[:3].mean())
            ratio = max(ratio, float(np.max(np.abs(nu - est.c) / np.maximum(est.hull, 1e-300))))
        print(f"{implementation:>6} {method:>10} {np.median(times) * 1e6:>8.0f} {np.median(full) * 1e6:>20.0f} {np.mean(frob):>14.4f} "
              f"{np.mean(width_xyz):>26.4f} {np.mean(width):>22.4f} {ratio:>19.3f}")


def controller_step_costs(fmu: Path) -> dict[str, float]:
    """The controller FMU's fmi2DoStep alone (one ctypes call), per estimator, at hover: median over 2000 ticks."""
    md = read_model_description(str(fmu))
    folder = extract(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    costs = {}
    try:
        for estimator in ("none", "lkf", "zse"):
            s = FMU2Slave(guid=md.guid, unzipDirectory=folder, modelIdentifier=md.coSimulation.modelIdentifier, instanceName="bench")
            s.instantiate()
            s.setupExperiment(startTime=0.0)
            s.enterInitializationMode()
            s.setString([vr["estimator"]], [estimator])
            s.exitInitializationMode()
            do_step = s.dll.fmi2DoStep
            do_step.argtypes = [ctypes.c_void_p, ctypes.c_double, ctypes.c_double, ctypes.c_int]
            times = []
            for k in range(2000):
                t = time.perf_counter()
                do_step(s.component, k * 0.012, 0.012, 1)
                times.append(time.perf_counter() - t)
            costs[estimator] = float(np.median(times[500:])) * 1e6
            s.terminate()
            s.freeInstance()
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    return costs


def main() -> None:
    steps = int(sys.argv[1]) if len(sys.argv) > 1 else 3000
    model = augmented_model()
    z = zse_setup(model)
    y0, data = record(model, z, steps)
    fmu = next(r.path for r in build_all(ROOT / "fmus", progress=print) if r.path.name == "TiltloadController.fmu")
    with tempfile.TemporaryDirectory() as tmp:
        lib = native_estimators.compile_library(fmu, Path(tmp))
        print(f"{steps} steps of {model.Tc * 1e3:.0f} ms, r_max = {z.r_max}, 23 states, up to 16 strips per step\n")
        print(f"{'impl.':>6} {'reduction':>10} {'us/step':>8} {'us/step (16 strips)':>20} {'mean F-radius':>14} "
              f"{'mean hull width x,y,z (m)':>26} {'mean hull width (all)':>22} {'max contain. ratio':>19}")
        args = (model.A, model.B, z.H, np.zeros(23), z.G_w, z.y_eq, z.G_v, z.r_max)
        zse_rows("C", lambda m: native_estimators.CZonotopicEstimator(lib, *args, m), model, z, y0, data, steps)
        zse_rows("Python", lambda m: ZonotopicEstimator(*args, m), model, z, y0, data, steps)
        print("(contain. ratio: max over steps and states of |error| / interval-hull half-width; <= 1 means inside)")

        s = lkf_setup()
        for name, f in (("C", native_estimators.CKalmanFilter(lib, model.A, model.B, s.H, s.Pw, s.Pv, np.zeros(23), s.P0)),
                        ("Python", KalmanFilter(model.A, model.B, s.H, s.Pw, s.Pv, np.zeros(23), s.P0))):
            times = []
            for du, _, nu in data:
                dy = s.H @ nu
                t = time.perf_counter()
                f.step(du, dy)
                times.append(time.perf_counter() - t)
            print(f"LKF (Alg. 4.1, 10 measurements), {name}: {np.median(times) * 1e6:.1f} us/step (median)")

    c, Gt = np.zeros(23), z.G_x0.T[np.any(z.G_x0 != 0, axis=0)]
    for k, (du, y, _) in enumerate(data[:60], start=1):
        c, Gt = textbook_step(model, z, c, Gt, du, y, np.flatnonzero(schedule(k)))
    t = time.perf_counter()
    for k, (du, y, _) in enumerate(data[60:90], start=61):
        c, Gt = textbook_step(model, z, c, Gt, du, y, np.flatnonzero(schedule(k)))
    print(f"textbook Alg. 4.4 in numpy (hstack per strip, same reduction): {(time.perf_counter() - t) / 30 * 1e6:.0f} us/step")

    costs = controller_step_costs(fmu)
    print("\ncontroller FMU, fmi2DoStep alone (estimator + law + feedforward), median us per tick: "
          + ", ".join(f"{k} {v:.1f}" for k, v in costs.items()) + "  (none = the FSI law)")


if __name__ == "__main__":
    main()

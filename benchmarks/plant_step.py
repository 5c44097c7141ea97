"""Cost of one 12 ms communication step of the plant FMU through FMPy (DESIGN §8 target <= 50 us).

Measured: a set of the 7 inputs + doStep(12 ms) + get of the 20 states, single process, wall
clock (perf_counter), best of 5 runs of 250 steps (3 s of hover at the trim inputs: the open-loop
plant is unstable, so each run starts again from the trim after fmi2Reset); then its parts:
the bare compiled RK4 (ctypes) and the FMI call overhead with a zero-length step. Also prints the RK4 accuracy per integrator step
against a DOP853 reference (rtol 1e-13) and the time of a fresh build.

Run: python benchmarks/plant_step.py
"""

from __future__ import annotations

import shutil
import tempfile
import time
from pathlib import Path

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
from scipy.integrate import solve_ivp
from tiltload.master.pythonfmu_guard import pin
from tiltload.plant_fmu import build as plant_build
from tiltload.plant_fmu import parameters as P
from tiltload.plant_fmu.native import NativePlant
from tiltload.plant_fmu.trim import hover_trim

ROOT = Path(__file__).resolve().parents[1]
N_STEPS, REPEATS, DT = 250, 5, 0.012


def fmi_step_cost(fmu: Path, integrator_step: float) -> tuple[float, float]:
    md = read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    d = extract(str(fmu))
    s = FMU2Slave(guid=md.guid, unzipDirectory=d, modelIdentifier="TiltloadPlant", instanceName="bench")
    s.instantiate()
    ins = [vr[n] for n in ("f_R", "f_L", "tau_R", "tau_L", "d_x", "d_y", "d_z")]
    outs = [vr[n] for n in P_STATES]
    u = hover_trim().u.tolist() + [0.0, 0.0, 0.0]
    best = best_zero = np.inf
    for _ in range(REPEATS):
        s.reset()
        s.setupExperiment(startTime=0.0)
        s.enterInitializationMode()
        s.setReal([vr["integrator_step"]], [integrator_step])
        s.exitInitializationMode()
        t = 0.0
        start = time.perf_counter()
        for _ in range(N_STEPS):
            s.setReal(ins, u)
            s.doStep(t, DT)
            t += DT
            s.getReal(outs)
        best = min(best, (time.perf_counter() - start) / N_STEPS)
        start = time.perf_counter()
        for _ in range(N_STEPS):
            s.setReal(ins, u)
            s.doStep(t, 0.0)
            s.getReal(outs)
        best_zero = min(best_zero, (time.perf_counter() - start) / N_STEPS)
    s.terminate()
    s.fmi2FreeInstance(s.component)
    return best * 1e6, best_zero * 1e6


def native_cost(lib: NativePlant, n: int) -> float:
    trim = hover_trim()
    x, u, dist, p = trim.x.copy(), trim.u.copy(), np.zeros(3), P.default_vector()
    y = np.empty(15)
    lib.bind(x, u, dist, p, y)
    best = np.inf
    for _ in range(REPEATS):
        x[:] = trim.x  # open loop: start each run at the trim again
        start = time.perf_counter()
        for _ in range(N_STEPS):
            lib.step(DT / n, n)
        best = min(best, (time.perf_counter() - start) / N_STEPS)
    return best * 1e6


def accuracy(lib: NativePlant) -> list[tuple[float, float, float]]:
    """Max state error after 0.504 s from a strongly perturbed hover, per integrator step."""
    trim, p = hover_trim(), P.default_vector()
    x0 = trim.x + 0.02 * np.random.default_rng(2).normal(size=20)
    zero = np.zeros(3)
    ref = solve_ivp(lambda t, x: lib.xdot(x, trim.u, zero, p), (0, 42 * DT), x0, method="DOP853",
                    rtol=1e-13, atol=1e-14).y[:, -1]
    rows = []
    for n in (1, 2, 3, 4, 6, 12):
        x = x0.copy()
        for _ in range(42):
            _, x = lib.advance(x, trim.u, zero, p, DT / n, n)
        err = np.abs(x - ref)
        rows.append((DT / n, err[:10].max(), err[10:].max()))
    return rows, float(np.abs(ref - trim.x).max())


P_STATES = [n for n in ("x y z phi theta psi gamma_1 gamma_2 alpha_R alpha_L".split())]
P_STATES = P_STATES + [f"{n}_dot" for n in P_STATES]


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        fresh = plant_build.build(Path(tmp), force=True)
        build_s = time.perf_counter() - start
        print(f"fresh build of the plant FMU (codegen + gcc -O3 + trim + packaging): {build_s:.1f} s")
        fmu = ROOT / "fmus" / fresh.path.name
        fmu.parent.mkdir(exist_ok=True)
        shutil.copy2(fresh.path, fmu)
    pin(fmu)
    unzip = extract(str(fmu))
    lib_path = next(Path(unzip).glob("resources/*_lib/tl_plant.so"))
    lib = NativePlant(lib_path)
    print(f"\nplant communication step of {DT * 1e3:.0f} ms, best of {REPEATS} x {N_STEPS} steps:")
    print(f"{'integrator step':>16} {'substeps':>9} {'compiled RK4':>13} {'FMPy set+doStep+get':>20}")
    for n in (3, 4, 12):
        full, zero = fmi_step_cost(fmu, DT / n)
        print(f"{DT / n * 1e3:>13.1f} ms {n:>9d} {native_cost(lib, n):>10.1f} us {full:>17.1f} us")
    print(f"FMI call overhead alone (set+doStep(0)+get): {zero:.1f} us  | default integrator step: "
          f"{plant_build.DEFAULT_INTEGRATOR_STEP * 1e3:.0f} ms | target <= 50 us per step")
    rows, excursion = accuracy(lib)
    print(f"\nRK4 accuracy after 0.504 s from a perturbed hover (max |x - x_trim| = {excursion:.2f}), "
          "vs DOP853 rtol 1e-13:")
    print(f"{'integrator step':>16} {'max q error':>12} {'max qdot error':>15}")
    for h, eq, ev in rows:
        print(f"{h * 1e3:>13.1f} ms {eq:>12.2e} {ev:>15.2e}")
    shutil.rmtree(unzip, ignore_errors=True)


if __name__ == "__main__":
    main()

"""Cost of the native FMUs' communication step, RK4 accuracy, build times (docs/native_fmus.md, Measured).

Measured, single process, wall clock (perf_counter), best of 5 runs of 250 steps:
- the plant: setReal(7 inputs) + doStep(12 ms) + getReal(20 states), per integrator step
  (target <= 10 us at the default 4 ms), two ways through FMPy: its list API (setReal/getReal
  build ctypes arrays on every call) and its raw fmi2SetReal/fmi2DoStep/fmi2GetReal on arrays
  allocated once (what a master's hot path does); then doStep alone through ctypes (the C cost
  plus one foreign call);
- the sensors (setReal of the 20 states + doStep + getReal of every Real output + getBoolean of
  the flags) and the scenario (doStep + getReal of its outputs), per tick, the same ways
  (target <= 5 us);
- RK4 accuracy per integrator step against DOP853 (rtol 1e-13) on CasADi's own model;
- a fresh build of each FMU (codegen + cc + packaging).

The plant is open-loop unstable: each run restarts from the trim with fmi2Reset.
Run: python benchmarks/plant_step.py
"""

from __future__ import annotations

import ctypes
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
from scipy.integrate import solve_ivp
from tiltload.native_fmu.build import build
from tiltload.plant_fmu import build as plant_build
from tiltload.plant_fmu import codegen
from tiltload.plant_fmu import parameters as P
from tiltload.plant_fmu.interface import STATE_NAMES
from tiltload.plant_fmu.trim import hover_trim
from tiltload.scenario_fmu import build as scenario_build
from tiltload.sensor_fmu import build as sensor_build

N_STEPS, REPEATS, DT = 250, 5, 0.012


class Bench:
    """One FMU instance driven by FMPy, restartable from its start values."""

    def __init__(self, fmu: Path, name: str) -> None:
        self.md = read_model_description(str(fmu))
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.dir = extract(str(fmu))
        self.s = FMU2Slave(guid=self.md.guid, unzipDirectory=self.dir, modelIdentifier=name, instanceName="bench")
        self.s.instantiate()
        self.outputs = {t: [v.valueReference for v in self.md.modelVariables if v.causality == "output" and v.type == t]
                        for t in ("Real", "Boolean")}

    def restart(self, **params) -> None:
        self.s.reset()
        self.s.setupExperiment(startTime=0.0)
        self.s.enterInitializationMode()
        for name, value in params.items():
            self.s.setReal([self.vr[name]], [value])
        self.s.exitInitializationMode()

    def best(self, loop, **params) -> float:
        best = np.inf
        for _ in range(REPEATS):
            self.restart(**params)
            start = time.perf_counter()
            loop()
            best = min(best, (time.perf_counter() - start) / N_STEPS)
        return best * 1e6

    def raw(self, type_: str, names_or_vrs, values=None):
        """Preallocated ctypes arrays for FMPy's raw fmi2Get/Set<type_> (no per-call conversion)."""
        ctype = {"Real": ctypes.c_double, "Boolean": ctypes.c_int}[type_]
        vrs = [self.vr[n] if isinstance(n, str) else n for n in names_or_vrs]
        vr_arr = (ctypes.c_uint * len(vrs))(*vrs)
        val_arr = (ctype * len(vrs))(*(values or [0] * len(vrs)))
        return vr_arr, len(vrs), val_arr

    def close(self) -> None:
        self.s.terminate()
        self.s.freeInstance()
        shutil.rmtree(self.dir, ignore_errors=True)


def plant_costs(fmu: Path, integrator_step: float) -> tuple[float, float, float]:
    b = Bench(fmu, "TiltloadPlant")
    s = b.s
    names_in = ("f_R", "f_L", "tau_R", "tau_L", "d_x", "d_y", "d_z")
    ins, outs = [b.vr[n] for n in names_in], [b.vr[n] for n in STATE_NAMES]
    u = hover_trim().u.tolist() + [0.0, 0.0, 0.0]
    vr_in, n_in, val_in = b.raw("Real", names_in, u)
    vr_out, n_out, val_out = b.raw("Real", STATE_NAMES)

    def listed():
        for k in range(N_STEPS):
            s.setReal(ins, u)
            s.doStep(k * DT, DT)
            s.getReal(outs)

    def raw():
        c = s.component
        for k in range(N_STEPS):
            s.fmi2SetReal(c, vr_in, n_in, val_in)
            s.fmi2DoStep(c, k * DT, DT, 1)
            s.fmi2GetReal(c, vr_out, n_out, val_out)

    do_step = s.dll.fmi2DoStep  # the bare C call: argument types fixed once
    do_step.argtypes = [ctypes.c_void_p, ctypes.c_double, ctypes.c_double, ctypes.c_int]
    do_step.restype = ctypes.c_int

    def bare():
        for k in range(N_STEPS):
            do_step(s.component, k * DT, DT, 1)

    costs = tuple(b.best(loop, integrator_step=integrator_step) for loop in (listed, raw, bare))
    b.close()
    return costs


def sampler_costs(fmu: Path, name: str, inputs: list[str], values: list[float]) -> tuple[float, float, float]:
    """Sensors or scenario per tick: set inputs, doStep, get every output; list API, raw arrays, bare doStep."""
    b = Bench(fmu, name)
    s = b.s
    ins = [b.vr[n] for n in inputs]
    raw_in = b.raw("Real", inputs, values) if inputs else None
    raw_out = {t: b.raw(t, vrs) for t, vrs in b.outputs.items() if vrs}

    def listed():
        for k in range(N_STEPS):
            if ins:
                s.setReal(ins, values)
            s.doStep(k * DT, DT)
            s.getReal(b.outputs["Real"])
            if b.outputs["Boolean"]:
                s.getBoolean(b.outputs["Boolean"])

    def raw():
        c = s.component
        getters = [(s.fmi2GetReal if t == "Real" else s.fmi2GetBoolean, arrays) for t, arrays in raw_out.items()]
        for k in range(N_STEPS):
            if raw_in:
                s.fmi2SetReal(c, *raw_in)
            s.fmi2DoStep(c, k * DT, DT, 1)
            for get, arrays in getters:
                get(c, *arrays)

    def bare():
        do_step = s.dll.fmi2DoStep
        do_step.argtypes = [ctypes.c_void_p, ctypes.c_double, ctypes.c_double, ctypes.c_int]
        for k in range(N_STEPS):
            do_step(s.component, k * DT, DT, 1)

    costs = tuple(b.best(loop) for loop in (listed, raw, bare))
    b.close()
    return costs


def accuracy() -> tuple[list[tuple[float, float, float]], float]:
    """Max state error after 0.504 s from a strongly perturbed hover, per integrator step (CasADi's VM)."""
    rhs, rk4, _ = codegen.functions()
    trim, p = hover_trim(), P.default_vector()
    x0 = trim.x + 0.02 * np.random.default_rng(2).normal(size=20)
    zero = np.zeros(3)
    ref = solve_ivp(lambda t, x: np.asarray(rhs(x, trim.u, zero, p)).ravel(), (0, 42 * DT), x0, method="DOP853",
                    rtol=1e-13, atol=1e-14).y[:, -1]
    rows = []
    for n in (1, 2, 3, 4, 6, 12):
        x = x0.copy()
        for _ in range(42 * n):
            x = np.asarray(rk4(x, trim.u, zero, p, DT / n)).ravel()
        err = np.abs(x - ref)
        rows.append((DT / n, err[:10].max(), err[10:].max()))
    return rows, float(np.abs(ref - trim.x).max())


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        fmus = {}
        for name, module in (("plant", plant_build), ("sensors", sensor_build), ("scenario", scenario_build)):
            start = time.perf_counter()
            fmus[name] = build(module.recipe(), Path(tmp), force=True).path
            print(f"fresh build of the {name} FMU (codegen + cc + packaging): {time.perf_counter() - start:.2f} s")
        print(f"\nplant communication step of {DT * 1e3:.0f} ms, best of {REPEATS} x {N_STEPS} steps:")
        print(f"{'integrator step':>16} {'substeps':>9} {'doStep (C)':>11} {'FMPy raw arrays':>16} {'FMPy list API':>14}")
        for n in (3, 4, 12):
            listed, raw, bare = plant_costs(fmus["plant"], DT / n)
            print(f"{DT / n * 1e3:>13.1f} ms {n:>9d} {bare:>8.1f} us {raw:>13.1f} us {listed:>11.1f} us")
        print(f"(set 7 + doStep + get 20; default integrator step {plant_build.DEFAULT_INTEGRATOR_STEP * 1e3:.0f} ms; "
              "target <= 10 us per step)")
        x = hover_trim().x.tolist()
        print(f"\nper tick (target <= 5 us): {'doStep (C)':>11} {'FMPy raw arrays':>16} {'FMPy list API':>14}")
        for name, fmu, ins, vals in (("sensors", fmus["sensors"], list(STATE_NAMES), x), ("scenario", fmus["scenario"], [], [])):
            listed, raw, bare = sampler_costs(fmu, f"Tiltload{name.capitalize()}", ins, vals)
            print(f"{name:>25} {bare:>8.1f} us {raw:>13.1f} us {listed:>11.1f} us")
        print("(sensors: set 20 + doStep + get 74 Reals and 9 flags; scenario: doStep + get 19 Reals)")
    rows, excursion = accuracy()
    print(f"\nRK4 accuracy after 0.504 s from a perturbed hover (max |x - x_trim| = {excursion:.2f}), vs DOP853 rtol 1e-13:")
    print(f"{'integrator step':>16} {'max q error':>12} {'max qdot error':>15}")
    for h, eq, ev in rows:
        print(f"{h * 1e3:>13.1f} ms {eq:>12.2e} {ev:>15.2e}")


if __name__ == "__main__":
    main()

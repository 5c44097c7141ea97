"""The controller+estimator FMU: its C equals the Python runtime it replaces tick by tick; the ZSE contains the
truth; the four FMUs in a C master without Python and in libcosim without numpy."""

from __future__ import annotations

import json
import os
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy.fmi1 import FMICallException
from fmpy.validation import validate_fmu
from support import HOSTS, T
from support.fmi2_session import session
from tiltload.controller_fmu.design import feedforward as ff
from tiltload.controller_fmu.fmu.build import bundle
from tiltload.controller_fmu.reference.runtime import ControllerRuntime
from tiltload.master.app.loop.thesis import default_system
from tiltload.master.engine import connections
from tiltload.master.engine.execution import Execution
from tiltload.master.engine.fmi.model_description import read_fmu
from tiltload.plant_fmu.interface import STATE_NAMES
from tiltload.sensor_fmu.suite import GROUPS, ZSE_NAMES

ZSE_GROUPS = [g for g in GROUPS if g.source == "pi"]


EXTENDED = list(STATE_NAMES) + ["d_x", "d_y", "d_z"]


@pytest.fixture(scope="module")
def design_bundle():
    return bundle(T, progress=lambda *_: None)


@pytest.mark.parametrize("controller, estimator, reduction, delay", [
    ("dlqr", "none", "combastel", 0), ("mixed", "none", "combastel", 0), ("dlqr", "lkf", "combastel", 0),
    ("mixed", "lkf", "combastel", 0), ("dlqr", "zse", "combastel", 0), ("mixed", "zse", "combastel", 0),
    ("mixed", "zse", "girard", 0), ("mixed", "none", "combastel", 1), ("dlqr", "lkf", "combastel", 2),
    ("mixed", "zse", "combastel", 2)])
def test_c_controller_equals_the_python_runtime(pipeline_fmus, design_bundle, controller, estimator, reduction, delay):
    """Closed loop with the plant and the sensors, 300 ticks from a 10 cm offset: u and the bounds, tick by tick.
    With a delay-aware design (delay d), each command reaches the plant d ticks after it is computed."""
    start = [0.1, -0.1, 0.1]
    rt = ControllerRuntime(design_bundle, controller, estimator, ff.bound(design_bundle["params"]), (0.0, 30.0, 2.0),
                           np.array(start), reduction, loop_delay=delay)
    on_the_way = [design_bundle["trim_u"]] * delay
    meas, lkf, exact = [f"meas_{n}" for n in ZSE_NAMES], [f"lkf_{n}" for n in STATE_NAMES[:10]], [f"exact_{n}" for n in STATE_NAMES]
    flags = [f"{g.name}_new" for g in ZSE_GROUPS]
    with session(pipeline_fmus["TiltloadPlant"], instance="plant") as plant, \
            session(pipeline_fmus["TiltloadSensors"], instance="sensors") as sensors, \
            session(pipeline_fmus["TiltloadController"], instance="controller") as ctrl:
        plant.set(**dict(zip(("x_0", "y_0", "z_0"), start)))
        ctrl.set(**dict(zip(("x_0", "y_0", "z_0"), start)))
        ctrl.set_typed(controller=controller, estimator=estimator, zse_reduction=reduction, loop_delay_ticks=delay)
        for s in (plant, sensors, ctrl):
            s.start()
        worst_u = worst_bounds = 0.0
        for k in range(300):
            sensors.set(**dict(zip(STATE_NAMES, plant.get(*STATE_NAMES))))
            sensors.fmu.doStep(k * T, T)
            y, q, x, fresh = sensors.get(*meas), sensors.get(*lkf), sensors.get(*exact), sensors.get_bool(*flags)
            ctrl.set(**dict(zip(meas, y)), **dict(zip(lkf, q)), **dict(zip(exact, x)))
            ctrl.set_typed(**dict(zip(flags, fresh)))
            ctrl.fmu.doStep(k * T, T)
            available = np.zeros(16, dtype=bool)
            for g, f in zip(ZSE_GROUPS, fresh):
                available[list(g.indices)] = f
            u_ref = rt.step(np.zeros(11), x, q, y, available)
            u = ctrl.get("f_R", "f_L", "tau_R", "tau_L")
            worst_u = max(worst_u, np.abs(u - u_ref).max())
            lo, hi = ctrl.get(*[f"est_{n}_lo" for n in EXTENDED]), ctrl.get(*[f"est_{n}_hi" for n in EXTENDED])
            worst_bounds = max(worst_bounds, np.abs(lo - rt.lower).max(), np.abs(hi - rt.upper).max())
            on_the_way.append(u)
            plant.set(**dict(zip(("f_R", "f_L", "tau_R", "tau_L"), on_the_way.pop(0))))
            plant.fmu.doStep(k * T, T)
        assert np.abs(plant.get("x", "y", "z")).max() < 0.3  # the loop is closed and stable (ZSE: a few cm of error)
    assert worst_u <= 1e-9 and worst_bounds <= 1e-9, (worst_u, worst_bounds)


def test_controller_fmu_is_native_and_valid(pipeline_fmus, tmp_path):
    fmu = pipeline_fmus["TiltloadController"]
    assert validate_fmu(str(fmu)) == []
    with zipfile.ZipFile(fmu) as z:
        assert not [n for n in z.namelist() if n.endswith((".py", ".npz"))]
        z.extract("binaries/linux64/TiltloadController.so", tmp_path)
    binary = tmp_path / "binaries" / "linux64" / "TiltloadController.so"
    libs = subprocess.run(["ldd", str(binary)], capture_output=True, text=True, check=True).stdout
    assert {line.split()[0] for line in libs.splitlines() if "=>" in line} <= {"libc.so.6", "libm.so.6"}  # no BLAS, no Python


def _plan(system, folder: Path, ticks: int, record: list[str]) -> Path:
    """The C master's plan for a tiltload system: binaries, parameters, connections, what to print."""
    mds = {i.name: read_fmu(i.fmu, i.name) for i in system.instances}
    lines = []
    for inst in system.instances:
        unpacked = folder / inst.name
        with zipfile.ZipFile(inst.fmu) as z:
            z.extractall(unpacked)
        md = mds[inst.name]
        lines.append(f"F {inst.name} {unpacked / 'binaries' / 'linux64' / (md.coSimulation.modelIdentifier + '.so')} {md.guid}")
        variables = {v.name: v for v in md.modelVariables}
        for key, value in inst.parameters.items():
            v = variables[key]
            code = {"Real": "R", "Integer": "I", "Boolean": "B", "String": "S"}[v.type]
            text = str(int(value)) if code in "IB" else (repr(float(value)) if code == "R" else str(value))
            lines.append(f"P {inst.name} {code} {v.valueReference} {text}")
    for link in connections.resolve(system, mds):
        assert link.delay == 0
        lines.append(f"C {link.source} {link.type[0]} {link.source_vr} {link.target} {link.target_vr}")
    lines.append(f"T {system.tick!r} {ticks}")
    plant = {v.name: v.valueReference for v in mds["plant"].modelVariables}
    lines += [f"O plant {plant[n]}" for n in record]
    path = folder / "plan.txt"
    path.write_text("\n".join(lines) + "\n")
    return path


def test_all_four_fmus_run_in_a_c_master_without_python(pipeline_fmus, tmp_path):
    """ZSE, trajectory 1, mixed design, 5 s: the C master's final plant state equals tiltload's master's."""
    fmus = pipeline_fmus["TiltloadPlant"].parent
    system = default_system(fmus, "zse", 1, "mixed", seed=3)
    ticks = round(5.0 / T)
    plan = _plan(system, tmp_path, ticks, list(STATE_NAMES))
    host = tmp_path / "loop_host"
    src = tmp_path / "plant" / "sources"
    subprocess.run(["cc", "-std=c11", "-Wall", "-Wextra", "-Werror", f"-I{src}", str(HOSTS / "loop_host.c"), "-o", str(host),
                    "-ldl", "-lm"], check=True)
    proc = subprocess.run(["env", "-i", str(host), str(plan)], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    c_master = np.array([float(line.split()[2]) for line in proc.stdout.splitlines() if line.startswith("plant ")])
    ours = Execution(system)
    try:
        ours.instantiate()
        ours.run(ticks * T)
        plant = ours.instances["plant"]
        final = np.array(plant.slave.getReal([plant.vars[n].valueReference for n in STATE_NAMES]))
    finally:
        ours.close()
    np.testing.assert_allclose(c_master, final, rtol=0, atol=1e-12)
    assert abs(final[0] - 2 * np.cos(np.pi * 5.0 / 20)) < 0.5  # on its way round the circle


@pytest.mark.slow
def test_all_four_fmus_run_in_libcosim_without_numpy(pipeline_fmus, libcosim_python):  # noqa: F811
    """libcosim steps all four for 1 s: finite, near the start, the ZSE running.

    libcosim is a Jacobi master: every connection carries one tick of delay, which the thesis's designs
    do not tolerate (this loop diverges near t = 2 s there; docs/ports.md: the delay-aware
    designs). One second shows the four FMUs exchange values in another master."""
    folder = pipeline_fmus["TiltloadPlant"].parent
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTHON")}
    proc = subprocess.run([str(libcosim_python), str(HOSTS / "libcosim_loop.py"), str(folder), "1.0", "--controller"],
                          capture_output=True, text=True, timeout=300, env=env)
    line = next((ln for ln in proc.stdout.splitlines() if ln.startswith("RESULT ")), None)
    assert proc.returncode == 0 and line, proc.stdout[-2000:] + proc.stderr[-2000:]
    lc = json.loads(line[len("RESULT "):])
    assert all(np.isfinite(v) for v in lc.values() if isinstance(v, float))
    w = np.pi / 20 * lc["time"]  # trajectory 1 at the end of the run
    ref = np.array([2 * np.cos(w), 2 * np.sin(w), 9 - 8 * np.cos(w)])
    assert np.linalg.norm(np.array([lc["plant.x"], lc["plant.y"], lc["plant.z"]]) - ref) < 0.6  # heading for the path
    assert lc["controller.zse_generators"] > 100  # the ZSE ran
    assert 0.0 < lc["controller.f_R"] < 30.0




def test_zse_controller_keeps_the_true_state_inside_its_bounds(pipeline_fmus, opened):
    """Plant + sensors + ZSE-mode mixed controller in a test loop (not the master), hover, 10 cm start offset."""
    plant = opened(pipeline_fmus["TiltloadPlant"], "plant")
    plant.set(x_0=0.1, y_0=-0.1, z_0=0.1)
    sensors = opened(pipeline_fmus["TiltloadSensors"], "sensors")
    ctrl = opened(pipeline_fmus["TiltloadController"], "controller")
    ctrl.set_typed(controller="mixed", estimator="zse")
    for s in (plant, sensors, ctrl):
        s.start()
    flags = [f"{g.name}_new" for g in GROUPS if g.source == "pi"]
    meas = [f"meas_{n}" for n in ZSE_NAMES]
    ext = list(STATE_NAMES) + ["d_x", "d_y", "d_z"]
    worst, gps_teeth = -np.inf, []
    for k in range(250):
        t = k * T
        x = plant.get(*STATE_NAMES)
        sensors.set(**dict(zip(STATE_NAMES, x)))
        sensors.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=T)
        ctrl.set(**dict(zip(meas, sensors.get(*meas))))
        ctrl.set_typed(**dict(zip(flags, sensors.get_bool(*flags))))
        ctrl.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=T)
        lo, hi = ctrl.get(*[f"est_{n}_lo" for n in ext]), ctrl.get(*[f"est_{n}_hi" for n in ext])
        truth = np.r_[x, 0.0, 0.0, 0.0]
        worst = max(worst, np.max(np.maximum(lo - truth, truth - hi)))
        gps_teeth.append(hi[0] - lo[0])
        plant.set(**dict(zip(("f_R", "f_L", "tau_R", "tau_L"), ctrl.get("f_R", "f_L", "tau_R", "tau_L"))))
        plant.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=T)
    assert worst <= 0.0, f"true state outside the ZSE bounds by {worst:.3g}"
    x = plant.get("x", "y", "z")
    assert np.all(np.abs(x) < 0.1)  # the loop is closed and stable: back toward the hover point
    widths = np.array(gps_teeth[50:])
    assert np.all(np.diff(widths)[np.arange(50, 249) % 10 == 9] < 0)  # the x bound narrows at every GPS sample


def test_controller_refuses_a_step_that_is_not_tc(pipeline_fmus, opened):
    s = opened(pipeline_fmus["TiltloadController"], "ctrl")
    s.start()
    with pytest.raises(FMICallException) as err:
        s.fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=0.01)
    assert err.value.status == 3  # fmi2Error: a step of the wrong size is a host error
    assert any("is not the controller period T_c = 0.012 s" in line for line in s.log)

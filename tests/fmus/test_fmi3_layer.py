"""The generic FMI 3.0 layer (native_fmu/c/tl_fmi3.c) as the loop's FMUs show it: validation, units, the exported API,
warning-free C, FMPy's results equal to the FMI 2.0 FMUs' bit for bit, the status rules, reset, the state round trip,
a rebuild from sources/ with FMPy's own build (buildDescription.xml)."""

from __future__ import annotations

import re
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.validation import validate_fmu
from support import T
from support.fmi3_session import Session3, session3
from tiltload.native_fmu.package import fmi_header_dir

LOOP = ("TiltloadPlant", "TiltloadSensors", "TiltloadScenario", "TiltloadController")
CLOCKED = ("TiltloadSensorsClocked", "TiltloadControllerClocked")
EVERY = (*LOOP, "TiltrotorUAV", "TiltrotorSensors", "TiltrotorController", "FormationController", "TiltrotorTracker", *CLOCKED,
         "TiltrotorSensorsClocked", "TiltrotorControllerClocked")  # what `tiltload build --fmi 3` writes
HOVER = {"f_R": 9.987293721113877, "f_L": 10.02221862357339, "tau_R": 0.0, "tau_L": 0.0}


def _api() -> set[str]:
    header = (fmi_header_dir(3) / "fmi3Functions.h").read_text()
    return set(re.findall(r"FMI3_Export\s+fmi3\w+TYPE\s+(fmi3\w+);", header))


@pytest.fixture(scope="module")
def every3(fmi3_fmus) -> dict[str, Path]:
    """Every FMI 3.0 FMU, built by `tiltload build --fmi 3` (the loop's were built already; the rest once per cache)."""
    from tiltload.master.app.cli import main

    base = fmi3_fmus["TiltloadPlant"].parent.parent
    assert main(["build", "--fmi", "3", "--out", str(base)]) == 0
    return {name: base / "fmi3" / f"{name}.fmu" for name in EVERY}


@pytest.fixture(scope="module")
def unpacked3(every3, tmp_path_factory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("unpacked3")
    out = {}
    for name, fmu in every3.items():
        with zipfile.ZipFile(fmu) as z:
            z.extractall(root / name)
        out[name] = root / name
    return out


# ---- what FMI tools see ---------------------------------------------------------------------------------
@pytest.mark.parametrize("name", EVERY)
def test_fmpy_validate_finds_no_problem(every3, name):
    assert validate_fmu(str(every3[name])) == []  # the schema (model and build description) and FMPy's checks
    md = read_model_description(str(every3[name]))
    assert md.fmiVersion == "3.0" and md.coSimulation is not None and md.modelExchange is None
    cs = md.coSimulation
    assert cs.canGetAndSetFMUstate and cs.canSerializeFMUstate and cs.hasEventMode == name.endswith("Clocked")
    vrs = [v.valueReference for v in md.modelVariables]
    assert len(vrs) == len(set(vrs))  # unique across types
    assert [v.name for v in md.modelVariables if v.causality == "independent"] == ["time"]


@pytest.mark.parametrize("name", LOOP)
def test_model_structure_lists_every_output_and_the_initial_unknowns(fmi3_fmus, name):
    md = read_model_description(str(fmi3_fmus[name]))
    outputs = [v for v in md.modelVariables if v.causality == "output"]
    assert [u.variable for u in md.outputs] == outputs
    assert [u.variable for u in md.initialUnknowns] == outputs  # no clocks: every output is computed at initialization


def test_units_and_display_units(fmi3_fmus):
    md = read_model_description(str(fmi3_fmus["TiltloadPlant"]))
    units = {u.name: u for u in md.unitDefinitions}
    assert units["N"].baseUnit.kg == 1 and units["N"].baseUnit.m == 1 and units["N"].baseUnit.s == -2
    deg = {d.name: d for d in units["rad"].displayUnits}["deg"]
    assert deg.factor == pytest.approx(180 / np.pi, rel=1e-15)
    variables = {v.name: v for v in md.modelVariables}
    assert variables["phi"].unit == "rad" and variables["phi"].displayUnit == "deg"
    assert variables["phi_dot"].displayUnit == "deg/s" and variables["f_R"].unit == "N"
    assert variables["L_x"].unit == "kg.m2/s" and variables["time"].unit == "s"


@pytest.mark.parametrize("name", EVERY)
def test_binary_exports_exactly_the_fmi3_api_and_needs_only_libc_and_libm(unpacked3, name):
    model = read_model_description(str(unpacked3[name])).coSimulation.modelIdentifier
    binary = unpacked3[name] / "binaries" / "x86_64-linux" / f"{model}.so"
    defined = subprocess.run(["nm", "-D", "--defined-only", str(binary)], capture_output=True, text=True, check=True).stdout
    exported = {line.split()[-1] for line in defined.splitlines() if line.strip()}
    assert exported == _api() and len(exported) == 75  # FMPy resolves every one of them when it loads an FMU
    libs = subprocess.run(["ldd", str(binary)], capture_output=True, text=True, check=True).stdout
    assert {line.split()[0] for line in libs.splitlines() if "=>" in line} <= {"libc.so.6", "libm.so.6"}
    assert not (unpacked3[name] / "sources" / "fmi3Functions.h").exists()  # the importer supplies the headers


@pytest.mark.parametrize("name", (*LOOP, *CLOCKED))
def test_our_c_compiles_without_a_warning(unpacked3, name):
    src = unpacked3[name] / "sources"
    for c_file in sorted(src.glob("*.c")):
        if c_file.name.endswith("_gen.c"):
            continue
        proc = subprocess.run(["cc", "-std=c11", "-Wall", "-Wextra", "-Werror", "-O2", "-fsyntax-only", f"-I{src}",
                               f"-I{fmi_header_dir(3)}", str(c_file)], capture_output=True, text=True)
        assert proc.returncode == 0, proc.stderr


@pytest.mark.slow
def test_fmpy_rebuilds_the_scenario_from_its_build_description(fmi3_fmus, tmp_path):
    """sources/buildDescription.xml is enough for FMPy's own build (fmpy.build, CMake): the rebuilt FMU gives the same."""
    from fmpy.build import build_platform_binary

    folder = tmp_path / "scenario"
    with zipfile.ZipFile(fmi3_fmus["TiltloadScenario"]) as z:
        z.extractall(folder, [m for m in z.namelist() if not m.startswith("binaries/")])
    build_platform_binary(folder)
    assert (folder / "binaries" / "x86_64-linux" / "TiltloadScenario.so").is_file()
    kw = {"stop_time": 1.2, "output_interval": T, "start_values": {"trajectory": 1}}
    ours, rebuilt = simulate_fmu(str(fmi3_fmus["TiltloadScenario"]), **kw), simulate_fmu(str(folder), **kw)
    assert all(np.array_equal(ours[n], rebuilt[n]) for n in ours.dtype.names)


# ---- the same results as FMI 2.0 -------------------------------------------------------------------------
def _plant_inputs(stop: float) -> np.ndarray:
    """Hover thrust and gust-like forces on the load (open loop, the plant tips over within a second under uneven
    thrust; these keep it finite for 25 s while moving every state)."""
    t = np.arange(0.0, stop + T / 2, T)
    rows = [(ti, HOVER["f_R"], HOVER["f_L"], 0.0, 0.0, 0.02 * (ti > 1.0), -0.01 * np.sin(ti)) for ti in t]
    return np.array(rows, dtype=[("time", float), ("f_R", float), ("f_L", float), ("tau_R", float), ("tau_L", float),
                                 ("d_x", float), ("d_y", float)])


@pytest.mark.parametrize("name, start", [("TiltloadPlant", {"x_0": 0.3, "z_0": -0.2}),
                                         ("TiltloadScenario", {"trajectory": 2}),
                                         ("TiltloadSensors", {"seed": 7})])
def test_fmpy_simulate_equals_the_fmi2_fmu_bit_for_bit(pipeline_fmus, fmi3_fmus, name, start):
    kw = {"stop_time": 3.0, "output_interval": T, "start_values": start}
    if name == "TiltloadPlant":
        kw["input"] = _plant_inputs(3.0)
    fmi2 = simulate_fmu(str(pipeline_fmus[name]), **kw)
    fmi3 = simulate_fmu(str(fmi3_fmus[name]), **kw)
    assert fmi2.dtype.names == fmi3.dtype.names and len(fmi2) == len(fmi3) == 251
    for n in fmi2.dtype.names:
        assert np.array_equal(fmi2[n], fmi3[n]), n
    if name == "TiltloadPlant":
        assert np.ptp(fmi3["x"]) > 1e-3  # the inputs and the start state move it: a comparison of something


# ---- the status rules -------------------------------------------------------------------------------------
def _errors(s: Session3) -> list[str]:
    return [m for status, category, m in s.log if status == 3 and category == "logStatusError"]


def test_bad_parameter_is_an_error_naming_it_and_leaves_the_instance_terminated(fmi3_fmus):
    with session3(fmi3_fmus["TiltloadSensors"], instance="bad") as s:
        s.set(gps_period=-0.12)
        with pytest.raises(FMICallException) as err:
            s.fmu.exitInitializationMode()
        assert err.value.status == 3 and any("gps_period must be positive" in m for m in _errors(s))
        with pytest.raises(FMICallException) as err:  # fmi3Error ends in Terminated: no step, not even fmi3Terminate
            s.fmu.terminate()
        assert err.value.status == 3 and s.said("fmi3Terminate is not allowed in terminated")
        assert s.get("exact_x")  # get remains
        s.fmu.reset()  # and reset: back to the start values, a good run
        s.fmu.enterInitializationMode(startTime=0.0)
        s.fmu.exitInitializationMode()
        assert s.do_step(0.0, T)[0] == 0


def test_non_finite_input_is_an_error_naming_it(fmi3_fmus):
    with session3(fmi3_fmus["TiltloadPlant"], instance="nan") as s:
        s.fmu.exitInitializationMode()
        with pytest.raises(FMICallException) as err:
            s.set(f_R=float("nan"))
        assert err.value.status == 3 and any("non-finite input f_R = nan at t=0 s" in m for m in _errors(s))
        assert s.do_step(0.0, T)[0] == 3 and s.said("fmi3DoStep is not allowed in terminated")


def test_refused_step_is_a_discard_that_keeps_the_state_and_asks_to_stop(fmi3_fmus):
    with session3(fmi3_fmus["TiltloadPlant"], instance="diverge") as s:
        s.set(alpha_R_dot_0=1e160, gamma_1_dot_0=1e160)
        s.fmu.exitInitializationMode()
        before = s.reals("x", "alpha_R_dot")
        status, event, terminate, early, last = s.do_step(0.0, T)
        assert status == 2 and terminate and not event and not early and last == 0.0  # fmi3Discard, time not advanced
        assert any(st == 2 and cat == "logStatusDiscard" for st, cat, _ in s.log)
        assert np.array_equal(s.reals("x", "alpha_R_dot"), before) and s.get("time") == [0.0]
        assert s.do_step(0.0, T)[0] == 2 and s.said("plant stopped at t=0 s")  # every later step is refused too


def test_calls_in_the_wrong_state_are_errors_with_a_reason(fmi3_fmus):
    plant = fmi3_fmus["TiltloadPlant"]
    with session3(plant, instance="early", start=False) as s:
        assert s.do_step(0.0, T)[0] == 3 and s.said("fmi3DoStep is not allowed in instantiated")
    with session3(plant, instance="output") as s:
        with pytest.raises(FMICallException):
            s.set(x=1.0)
        assert s.said("cannot set x: it is an output")
    with session3(plant, instance="late") as s:
        s.fmu.exitInitializationMode()
        with pytest.raises(FMICallException):
            s.set(m_L=0.1)
        assert s.said("cannot set m_L: it is a parameter, fixed after initialization")
    with session3(plant, instance="event") as s:
        s.fmu.exitInitializationMode()
        with pytest.raises(FMICallException):
            s.fmu.enterEventMode()
        assert s.said("eventModeUsed = false")
    with session3(plant, instance="time") as s:
        s.fmu.exitInitializationMode()
        assert s.do_step(0.5, T)[0] == 3 and s.said("called at t=0.5 s but the FMU is at t=0 s")
    with session3(plant, instance="type") as s:
        with pytest.raises(FMICallException):
            s.fmu.getInt32([s.vr["x"]])  # a Float64 value reference
        assert s.said(f"value reference {s.vr['x']} is not a Int32 variable")
    with session3(plant, instance="stop", start=False) as s:
        s.fmu.enterInitializationMode(startTime=0.0, stopTime=2 * T)
        s.fmu.exitInitializationMode()
        assert s.do_step(0.0, T)[0] == 0 and s.do_step(T, T)[0] == 0
        assert s.do_step(2 * T, T)[0] == 3 and s.said("goes beyond the stop time")


def test_instantiation_refusals_say_why(fmi3_fmus, tmp_path):
    with pytest.raises(Exception, match="Failed to instantiate"):
        Session3(fmi3_fmus["TiltloadScenario"], instance="em", event_mode=True)  # the plain variant has no Event Mode
    foreign = tmp_path / "foreign.fmu"
    with zipfile.ZipFile(fmi3_fmus["TiltloadScenario"]) as src, zipfile.ZipFile(foreign, "w") as dst:
        for item in src.infolist():
            data = src.read(item)
            if item.filename == "modelDescription.xml":
                data = re.sub(rb'instantiationToken="[^"]+"', b'instantiationToken="{00000000-0000-0000-0000-000000000000}"', data)
            dst.writestr(item, data)
    s = Session3.__new__(Session3)
    with pytest.raises(Exception, match="Failed to instantiate"):
        s.__init__(foreign, "foreign")
    assert s.said("does not match this binary's"), s.log


def test_log_messages_escape_the_fmi3_escape_character(fmi3_fmus):
    with session3(fmi3_fmus["TiltloadSensors"], instance="esc") as s:
        s.set(gps_pdf="#1 cauchy")
        with pytest.raises(FMICallException):
            s.fmu.exitInitializationMode()
        assert s.said("gps_pdf must be one of gaussian, uniform, got '##1 cauchy'")


# ---- reset and FMU state -------------------------------------------------------------------------------------
def test_reset_restarts_from_the_start_values(fmi3_fmus):
    with session3(fmi3_fmus["TiltloadSensors"], instance="reset") as s:
        s.fmu.exitInitializationMode()

        def run():
            out = []
            for k in range(30):
                assert s.do_step(k * T, T)[0] == 0
                out.append(s.get("meas_x_B", "lkf_x", "gps_new"))
            return out
        first = run()
        s.fmu.reset()
        s.fmu.enterInitializationMode(startTime=0.0)
        s.fmu.exitInitializationMode()
        assert run() == first


# the open-loop plant tips over within seconds: its round trip is at 1.5 s (the closed loop's, at 20 s, is in
# tests/engine/test_fmi3_master.py)
@pytest.mark.parametrize("name, at_s", [("TiltloadPlant", 1.5), ("TiltloadSensors", 20.0), ("TiltloadScenario", 20.0)])
def test_state_serialized_continues_bit_for_bit_in_a_new_instance(fmi3_fmus, name, at_s):
    md = read_model_description(str(fmi3_fmus[name]))
    outputs = [v.name for v in md.modelVariables if v.causality == "output" and v.type == "Float64"]
    inputs = _plant_inputs(at_s + 1.5) if name == "TiltloadPlant" else None
    at, end = round(at_s / T), round((at_s + 1.5) / T)

    def drive(s, k0, k1):
        rows = []
        for k in range(k0, k1):
            if inputs is not None:
                s.set(**{n: float(inputs[n][k]) for n in inputs.dtype.names[1:]})
            assert s.do_step(k * T, T)[0] == 0
            rows.append(s.reals(*outputs))
        return np.array(rows)
    with session3(fmi3_fmus[name], instance="whole") as s:
        s.fmu.exitInitializationMode()
        drive(s, 0, at)
        blob = s.fmu.serializeFMUState(s.fmu.getFMUState())
        uninterrupted = drive(s, at, end)
    with session3(fmi3_fmus[name], instance="restored") as s:  # a new instance, still in initialization mode
        s.fmu.setFMUState(s.fmu.deserializeFMUState(blob))
        assert s.get("time") == [pytest.approx(at * T, abs=1e-9)]
        assert np.array_equal(drive(s, at, end), uninterrupted)
        with pytest.raises(FMICallException):  # bytes of another build or garbage are refused, with a reason
            s.fmu.deserializeFMUState(b"x" * len(blob))
        assert s.said("not a state of this")

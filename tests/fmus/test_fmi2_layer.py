"""The generic FMI 2.0 layer, as every native FMU shows it: libc/libm only, warning-free C, a C host without Python,
AddressSanitizer, validation and units, status semantics, snapshots, reset, threads, GUIDs, other importers (libcosim)."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import threading
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import fmi2Terminated
from fmpy.validation import validate_fmu
from support import HOSTS, NATIVE, TUMBLE, T
from support.fmi2_session import Session, session
from tiltload.plant_fmu.interface import STATE_NAMES
from tiltload.sensor_fmu.fmu_variables import channel_names
from tiltload.sensor_fmu.suite import GROUPS


@pytest.fixture(scope="module")
def unpacked(native, tmp_path_factory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("unpacked")
    out = {}
    for name, fmu in native.items():
        with zipfile.ZipFile(fmu) as z:
            z.extractall(root / name)
        out[name] = root / name
    return out


def _guid(folder: Path) -> str:
    return re.search(r'guid="([^"]+)"', (folder / "modelDescription.xml").read_text()).group(1)


# ---- what the binaries need ---------------------------------------------------------------------
@pytest.mark.parametrize("name", NATIVE)
def test_binaries_need_only_libc_and_libm(native, unpacked, name):
    binary = unpacked[name] / "binaries" / "linux64" / f"{name}.so"
    undefined = subprocess.run(["nm", "-D", "--undefined-only", str(binary)], capture_output=True, text=True, check=True).stdout
    assert not [s for s in undefined.split() if re.match(r"_?Py", s)], undefined
    libs = subprocess.run(["ldd", str(binary)], capture_output=True, text=True, check=True).stdout
    needed = {line.split()[0] for line in libs.splitlines() if "=>" in line}
    assert needed <= {"libc.so.6", "libm.so.6"}, needed
    defined = subprocess.run(["nm", "-D", "--defined-only", str(binary)], capture_output=True, text=True, check=True).stdout
    exported = {line.split()[-1] for line in defined.splitlines() if line.strip()}  # every kind: T, i (ifunc), W
    assert exported and all(s.startswith("fmi2") for s in exported), exported  # -fvisibility=hidden: only the API
    with zipfile.ZipFile(native[name]) as z:
        assert not [f for f in z.namelist() if f.endswith(".py")]


@pytest.mark.parametrize("name", NATIVE)
def test_our_c_compiles_without_a_warning(unpacked, name):
    """-Wall -Wextra -Werror on every source but CasADi's generated code (our own code has every warning on)."""
    src = unpacked[name] / "sources"
    for c_file in sorted(src.glob("*.c")):
        if c_file.name.endswith("_gen.c"):
            continue
        proc = subprocess.run(["cc", "-std=c11", "-Wall", "-Wextra", "-Werror", "-O2", "-fsyntax-only", f"-I{src}", str(c_file)],
                              capture_output=True, text=True)
        assert proc.returncode == 0, proc.stderr


def _law_file(tmp_path: Path, md) -> Path:
    """The DLQR gain and the trim for the C host's hover (the open-loop plant is unstable)."""
    from tiltload.controller_fmu.design.synthesize import design

    d = design("dlqr", T, use_cache=True)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    assert [vr[n] for n in STATE_NAMES] == list(range(vr["x"], vr["x"] + 20))
    assert [vr[n] for n in ("f_R", "f_L", "tau_R", "tau_L")] == list(range(vr["f_R"], vr["f_R"] + 4))
    numbers = [*d.trim_x, *d.trim_u, *np.asarray(d.K).ravel()]
    path = tmp_path / "law.txt"
    path.write_text(f"{vr['x']} {vr['f_R']}\n" + " ".join(repr(float(v)) for v in numbers))
    return path


def _run_host(host: Path, binary: Path, guid: str, law: Path) -> subprocess.CompletedProcess:
    # env -i: nothing of this Python's environment reaches the host process
    return subprocess.run(["env", "-i", str(host), str(binary), guid, "10", str(law)], capture_output=True, text=True, timeout=120)


def test_a_c_host_without_python_hovers_ten_seconds(unpacked, tmp_path):
    folder = unpacked["TiltloadPlant"]
    host = tmp_path / "host"
    subprocess.run(["cc", "-std=c11", "-Wall", "-Wextra", "-Werror", f"-I{folder / 'sources'}", str(HOSTS / "fmu_host.c"),
                    "-o", str(host), "-ldl", "-lm"], check=True)
    law = _law_file(tmp_path, read_model_description(str(folder)))
    proc = _run_host(host, folder / "binaries" / "linux64" / "TiltloadPlant.so", _guid(folder), law)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    drift = float(re.search(r"drift (\S+)", proc.stdout).group(1))
    assert drift <= 1e-9


@pytest.mark.slow
def test_fmu_rebuilt_from_its_sources_is_clean_under_address_sanitizer(unpacked, tmp_path):
    """sources/ holds everything needed to rebuild: compile the files the model description lists."""
    folder = unpacked["TiltloadPlant"]
    md = read_model_description(str(folder))
    import xml.etree.ElementTree as ET
    listed = [f.get("name") for f in ET.parse(folder / "modelDescription.xml").iter("File")]
    assert listed and all((folder / "sources" / f).is_file() for f in listed)
    src = folder / "sources"
    asan = ["-fsanitize=address", "-fno-omit-frame-pointer", "-g"]
    binary = tmp_path / "TiltloadPlant_asan.so"
    subprocess.run(["cc", "-std=c11", "-O1", "-fPIC", "-shared", *asan, "-DCASADI_SYMBOL_EXPORT=", f"-I{src}",
                    *(str(src / f) for f in listed), "-o", str(binary), "-lm"], check=True)
    host = tmp_path / "host_asan"
    subprocess.run(["cc", "-std=c11", *asan, f"-I{src}", str(HOSTS / "fmu_host.c"), "-o", str(host), "-ldl", "-lm"], check=True)
    proc = _run_host(host, binary, _guid(folder), _law_file(tmp_path, md))
    assert proc.returncode == 0, proc.stdout + proc.stderr  # ASan (and LeakSanitizer) exit non-zero on any finding
    assert "ERROR: AddressSanitizer" not in proc.stderr and "LeakSanitizer" not in proc.stderr


# ---- what FMI tools see ---------------------------------------------------------------------------
@pytest.mark.parametrize("name", NATIVE)
def test_validates_and_declares_units(native, name):
    assert validate_fmu(str(native[name])) == []
    md = read_model_description(str(native[name]))
    assert md.unitDefinitions and md.coSimulation.canGetAndSetFMUstate and md.coSimulation.canSerializeFMUstate
    reals = [v for v in md.modelVariables if v.type == "Real" and v.causality in ("input", "output")]
    with_unit = [v for v in reals if v.unit]
    assert len(with_unit) >= 0.9 * len(reals)
    units = {u.name: u for u in md.unitDefinitions}
    assert all(v.unit in units for v in with_unit)
    if name == "TiltloadPlant":
        assert units["N"].baseUnit.kg == 1 and units["N"].baseUnit.m == 1 and units["N"].baseUnit.s == -2
        assert {v.name: v.unit for v in md.modelVariables}["L_x"] == "kg.m2/s"


def test_fmpy_info_lists_units(native):
    out = subprocess.run([sys.executable, "-m", "fmpy.cli", "info", str(native["TiltloadPlant"])], capture_output=True, text=True,
                         check=True).stdout
    assert re.search(r"^\s+f_R\s+input\s+\S+\s+N\s", out, re.M), out


@pytest.mark.parametrize("name", NATIVE)
def test_fifty_simulations_in_one_process_are_identical(native, name):
    first = simulate_fmu(str(native[name]), stop_time=0.6)
    for _ in range(49):
        again = simulate_fmu(str(native[name]), stop_time=0.6)
        assert all(np.array_equal(first[n], again[n]) for n in first.dtype.names)


# ---- FMI behaviour ----------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["TiltloadPlant", "TiltloadSensors"])
def test_state_snapshot_and_serialization_replay_bit_for_bit(native, name):
    outputs = [v.name for v in read_model_description(str(native[name])).modelVariables
               if v.causality == "output" and v.type == "Real"]
    with session(native[name], instance="snap") as s:
        if name == "TiltloadPlant":
            s.set(**{f"{k}_0": v * 0.1 for k, v in TUMBLE.items()})
        s.start()
        for k in range(20):
            s.fmu.doStep(k * T, T)
        state = s.fmu.getFMUstate()
        blob = s.fmu.serializeFMUstate(state)
        first = [s.get(*outputs)]
        for k in range(20, 60):
            s.fmu.doStep(k * T, T)
            first.append(s.get(*outputs))
        for restore in (lambda: s.fmu.setFMUstate(state), lambda: s.fmu.setFMUstate(s.fmu.deSerializeFMUstate(blob))):
            restore()
            again = [s.get(*outputs)]
            for k in range(20, 60):
                s.fmu.doStep(k * T, T)
                again.append(s.get(*outputs))
            assert np.array_equal(np.array(first), np.array(again))
        s.fmu.freeFMUstate(state)
        with pytest.raises(FMICallException):  # bytes of another build or garbage are refused
            s.fmu.deSerializeFMUstate(b"x" * len(blob))


def test_reset_restarts_from_the_start_values(native):
    with session(native["TiltloadSensors"], instance="reset") as s:
        s.start()
        run = lambda: [s.fmu.doStep(k * T, T) or s.get("meas_x_B", "lkf_x")[0] for k in range(30)]  # noqa: E731
        first = run()
        s.fmu.reset()
        s.fmu.setupExperiment(startTime=0.0)
        s.fmu.enterInitializationMode()
        s.start()
        assert run() == first


def test_instances_on_two_threads_match_sequential_runs(native):
    def simulate(result, key, x0):
        with session(native["TiltloadPlant"], instance=key) as s:
            s.set(x_0=x0)
            s.start()
            result[key] = s.run(0.6, T, record=STATE_NAMES)
    sequential, parallel = {}, {}
    simulate(sequential, "a", 0.3)
    simulate(sequential, "b", -0.2)
    threads = [threading.Thread(target=simulate, args=(parallel, k, x0)) for k, x0 in (("a", 0.3), ("b", -0.2))]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    assert all(np.array_equal(sequential[k], parallel[k]) for k in "ab")
    assert not np.array_equal(sequential["a"], sequential["b"])


def test_fmi_status_semantics(native):
    """Error names the cause and blocks the instance; discard refuses a step and says the FMU stopped."""
    s = Session(native["TiltloadPlant"], "status")
    try:
        with pytest.raises(FMICallException) as err:
            s.set(x_B=1.0)  # an output
        assert err.value.status == 3 and any("cannot set x_B: it is an output" in line for line in s.log)
    finally:
        s.close()
    with session(native["TiltloadPlant"], instance="late") as s:
        s.start()
        with pytest.raises(FMICallException):
            s.set(m_L=0.1)
        assert any("cannot set m_L: it is a parameter, fixed after initialization" in line for line in s.log)
    with session(native["TiltloadPlant"], instance="clock") as s:
        s.start()
        with pytest.raises(FMICallException):
            s.fmu.doStep(0.5, T)
        assert any("called at t=0.5 s but the FMU is at t=0 s" in line for line in s.log)
    with session(native["TiltloadPlant"], instance="vr") as s:
        with pytest.raises(FMICallException):
            s.fmu.getReal([10_000])
        assert any("fmi2GetReal: value reference 10000 is not a Real variable of TiltloadPlant" in line for line in s.log)
    with session(native["TiltloadPlant"], instance="unsupported") as s:
        s.start()
        with pytest.raises(FMICallException) as err:
            s.fmu.getDirectionalDerivative([0], [1], [1.0])
        assert err.value.status == 3 and any("fmi2GetDirectionalDerivative is not supported by TiltloadPlant" in line
                                             for line in s.log)
        with pytest.raises(FMICallException):  # an error, so the instance is in its error phase: no more steps
            s.fmu.doStep(0.0, T)
        assert any("fmi2DoStep is not allowed in error" in line for line in s.log)
    with session(native["TiltloadPlant"], instance="diverge") as s:
        s.set(alpha_R_dot_0=1e160, gamma_1_dot_0=1e160)
        s.start()
        with pytest.raises(FMICallException) as err:
            s.fmu.doStep(0.0, T)
        assert err.value.status == 2  # fmi2Discard
        assert s.fmu.getBooleanStatus(fmi2Terminated)  # the plant asks the master to stop
        assert s.fmu.getRealStatus(2) == 0.0  # fmi2LastSuccessfulTime: the refused step did not advance


def test_instantiate_with_a_foreign_guid_fails_with_a_reason(native, tmp_path):
    foreign = tmp_path / "foreign.fmu"
    with zipfile.ZipFile(native["TiltloadScenario"]) as src, zipfile.ZipFile(foreign, "w") as dst:
        for item in src.infolist():
            data = src.read(item)
            if item.filename == "modelDescription.xml":
                data = re.sub(rb'guid="[^"]+"', b'guid="{00000000-0000-0000-0000-000000000000}"', data)
            dst.writestr(item, data)
    s = Session.__new__(Session)  # keep the object: its log holds the FMU's reason
    with pytest.raises(Exception, match="Failed to instantiate"):  # FMPy's words for a NULL instance
        s.__init__(str(foreign), "foreign")
    shutil.rmtree(s.dir, ignore_errors=True)
    assert any("does not match this binary's" in line for line in s.log), s.log


# ---- another master, from a Python without numpy -------------------------------------------------
LIBCOSIMPY = "libcosimpy==0.0.6"


def test_libcosim_runs_plant_sensors_and_scenario_without_numpy(native, libcosim_python):
    folder = native["TiltloadPlant"].parent
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTHON")}
    proc = subprocess.run([str(libcosim_python), str(HOSTS / "libcosim_loop.py"), str(folder), "2.4"], capture_output=True,
                          text=True, timeout=300, env=env)
    line = next((ln for ln in proc.stdout.splitlines() if ln.startswith("RESULT ")), None)
    assert proc.returncode == 0 and line, proc.stdout[-2000:] + proc.stderr[-2000:]
    lc = json.loads(line[len("RESULT "):])
    steps = round(lc["time"] / T)
    # the same three FMUs driven by FMPy, Jacobi-style as libcosim does (the sensors see the previous step's state)
    with session(native["TiltloadPlant"], instance="plant") as plant, \
            session(native["TiltloadSensors"], instance="sensors") as sensors, \
            session(native["TiltloadScenario"], instance="scenario") as scenario:
        for s in (plant, sensors, scenario):
            s.start()
        for k in range(steps):
            d = scenario.get("d_x", "d_y", "d_z")
            for s in (plant, sensors, scenario):
                s.fmu.doStep(k * T, T)
            sensors.set(**dict(zip(STATE_NAMES, plant.get(*STATE_NAMES))))
            plant.set(d_x=d[0], d_y=d[1], d_z=d[2])
        ours = {f"sensors.{n}": sensors.get(n)[0] for g in GROUPS for n in channel_names(g)}
        ours.update({f"plant.{n}": plant.get(n)[0] for n in STATE_NAMES})
        ours["scenario.x_ref"] = scenario.get("x_ref")[0]
    for key, value in ours.items():
        assert lc[key] == pytest.approx(value, abs=1e-9), key
    assert abs(lc["plant.x"]) < 1e-9  # hover at the trim (no gust before 10 s)


@pytest.mark.parametrize("fmu, typed, reals, needle", [
    ("TiltloadSensors", {}, {"gps_period": -0.12}, "gps_period must be positive"),
    ("TiltloadSensors", {}, {"baro_bound": -1.0}, "baro bound must be non-negative"),
    ("TiltloadSensors", {}, {"cam_xy_period": 0.03}, "cam_xy_period = 0.03 s is not a whole multiple"),
    ("TiltloadSensors", {"imu_att_pdf": "cauchy"}, {}, "imu_att_pdf must be one of"),
    ("TiltloadController", {"controller": "pid"}, {}, "unknown controller 'pid'"),
    ("TiltloadController", {"estimator": "ekf"}, {}, "unknown estimator 'ekf'"),
    ("TiltloadScenario", {"trajectory": 9}, {}, "trajectory must be 0 to 8"),
    ("TiltloadScenario", {"trajectory": 4}, {}, "trajectory 4 needs waypoints_file"),
    ("TiltloadScenario", {"trajectory": 4, "waypoints_file": "/nonexistent/mission.csv"}, {},
     "waypoints_file /nonexistent/mission.csv: No such file or directory"),
    ("TiltloadScenario", {"trajectory": 4, "waypoints_file": "/dev/null"}, {}, "waypoints_file /dev/null: not a regular file"),
    ("TiltloadScenario", {"trajectory": 5}, {"shape_period": 0.0}, "shape_period must be > 0"),
    ("TiltloadScenario", {"dryden": 2}, {"dryden_altitude": 1000.0}, "dryden_altitude must be 3.048 to 304.8 m"),
    ("TiltloadScenario", {"dryden": 4}, {}, "dryden must be 0 (none), 1 light, 2 moderate or 3 severe"),
    ("TiltloadScenario", {"wind_profile_count": 2}, {}, "wind_profile_t_1 is not after wind_profile_t_0"),
])
def test_bad_parameters_fail_initialization_naming_them(pipeline_fmus, opened, fmu, typed, reals, needle):
    s = opened(pipeline_fmus[fmu], "bad")
    if typed:
        s.set_typed(**typed)
    if reals:
        s.set(**reals)
    with pytest.raises(FMICallException) as err:
        s.start()
    assert err.value.status == 3  # fmi2Error, with the reason in the log
    assert any(needle in line for line in s.log), s.log

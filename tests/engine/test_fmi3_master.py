"""The engine's FMI 3.0 slave (master/engine/fmi/fmi3.py): the loop on FMI 3.0 FMUs with and without clocks, mixed with
FMI 2.0 ones, equals the FMI 2.0 loop bit for bit; the log shows each clocked sensor group sampled at its clock's
ticks; clocks replace periods; a state saved at 20 s continues bit for bit in new instances; two other importers
agree: FMPy's FMU3Slave stepping the plain FMUs, and a C host written from the standard's call sequences stepping
the clocked ones."""

from __future__ import annotations

import json
import subprocess
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from support import HOSTS, T
from support.fmi3_plan import host_plan
from support.fmi3_session import Session3
from tiltload.master.app.loop.thesis import default_system, loop_metrics
from tiltload.master.engine import connections
from tiltload.master.engine import system as sysdesc
from tiltload.master.engine.errors import DescriptionError, ExecutionError
from tiltload.master.engine.execution import Execution
from tiltload.master.engine.fmi.model_description import read_fmu
from tiltload.master.engine.log.logger import McapLogger
from tiltload.master.engine.log.reader import read
from tiltload.master.engine.observers import Observer
from tiltload.master.engine.run import run_system
from tiltload.native_fmu.package import fmi_header_dir
from tiltload.plant_fmu.interface import STATE_NAMES
from tiltload.sensor_fmu.fmu_variables import channel_names
from tiltload.sensor_fmu.suite import GROUPS


@pytest.fixture(scope="module")
def fmi3_set(fmi3_fmus):
    """The FMI 3.0 folder with the clocked variants built too."""
    from tiltload.master.app.loop.fmus import build_all

    folder = fmi3_fmus["TiltloadPlant"].parent
    build_all(folder, progress=lambda *_: None, fmi_version=3, clocked=True)
    return folder


class Record(Observer):
    """Every instance's Real outputs after each of its steps."""

    def __init__(self) -> None:
        self.rows: dict[str, list[np.ndarray]] = {}

    def on_step(self, instance, t) -> None:
        self.rows.setdefault(instance.name, []).append(instance.values["Real"].copy())


def _run(system, stop, observers=()):
    ex = Execution(system, [*observers])
    try:
        ex.instantiate()
        ex.run(stop)
        return ex, {name: (inst.values["Real"].copy(), getattr(inst, "activations", None)) for name, inst in ex.instances.items()}
    finally:
        ex.close()


def _metrics(system, stop):
    r = run_system(system, stop, None, loop_metrics(), progress=False)
    assert r.error is None, r.error
    return r.metrics


# ---- the same loop, three ways ------------------------------------------------------------------------------
@pytest.mark.parametrize("scenario, controller", [("zse", "mixed"), ("lkf", "dlqr"), ("fsi", "mixed")])
def test_fmi3_loop_with_and_without_clocks_equals_fmi2_bit_for_bit(fmus, fmi3_set, scenario, controller):
    runs = {}
    for label, folder, kw in (("fmi2", fmus, {}), ("plain", fmi3_set, {"fmi": 3}), ("clocked", fmi3_set, {"fmi": 3, "clocked": True})):
        rec = Record()
        _run(default_system(folder, scenario, 1, controller, seed=4, **kw), 4.0, [rec])
        runs[label] = rec.rows
    for label in ("plain", "clocked"):
        for name in ("scenario", "sensors", "controller", "plant"):
            assert np.array_equal(np.array(runs[label][name]), np.array(runs["fmi2"][name])), (label, name)
    assert len(runs["clocked"]["plant"]) == round(4.0 / T)


def test_fmi2_and_fmi3_fmus_with_and_without_clocks_mix_in_one_system(fmus, fmi3_set):
    fmi2 = default_system(fmus, "zse", 1, "mixed")
    mixed = default_system(fmus, "zse", 1, "mixed")
    swap = {"scenario": fmi3_set / "TiltloadScenario.fmu", "sensors": fmi3_set / "TiltloadSensorsClocked.fmu",
            "controller": fmus / "TiltloadController.fmu", "plant": fmi3_set / "TiltloadPlant.fmu"}
    for inst in mixed.instances:
        inst.fmu = swap[inst.name]
    versions = {i.name: read_fmu(i.fmu, i.name).fmiVersion for i in mixed.instances}
    assert versions == {"scenario": "3.0", "sensors": "3.0", "controller": "2.0", "plant": "3.0"}
    assert _metrics(mixed, 3.0) == _metrics(fmi2, 3.0)


@pytest.mark.parametrize("fault, stop", [("gps_dropout", 17.0), ("camera_stale", 7.0), ("thrust_loss", 21.0),
                                         ("servo_stuck", 11.0)])
@pytest.mark.slow
def test_faults_act_on_the_clocked_loop_as_on_the_fmi2_loop(fmus, fmi3_set, fault, stop):
    """Manipulators on clocked outputs (held samples, flags), on connections into the plant and on unconnected inputs."""
    from support import ROOT
    from tiltload.master.engine.faults.parse import load as load_faults

    faults = load_faults(ROOT / "docs" / "faults" / f"{fault}.json")
    fmi2, clocked = default_system(fmus, "zse", 1, "mixed"), default_system(fmi3_set, "zse", 1, "mixed", fmi=3, clocked=True)
    fmi2.faults, clocked.faults = list(faults), list(faults)
    free = default_system(fmus, "zse", 1, "mixed")
    assert _metrics(clocked, stop) == _metrics(fmi2, stop) != _metrics(free, stop)  # the fault acts, alike


class RecordAll(Observer):
    """Every output of every instance after each of its steps, as bytes."""

    def __init__(self) -> None:
        self.rows: list[tuple[str, float, bytes]] = []

    def on_step(self, instance, t) -> None:
        self.rows.append((instance.name, t, b"".join(instance.values[typ].tobytes() for typ in ("Real", "Integer", "Boolean"))))


@pytest.mark.parametrize("clocked", [False, True], ids=["plain", "clocked"])
@pytest.mark.parametrize("fault, stop", [("gps_dropout", 17.0), ("thrust_loss", 21.0), ("servo_stuck", 11.0)])
def test_the_kernel_s_own_fmi3_calls_equal_the_python_path_bit_for_bit(fmi3_set, fault, stop, clocked, monkeypatch):
    """The C loop calls FMI 3.0 FMUs' fmi3 functions itself, a clocked one's Event Mode included (native/clocks.py);
    forced through the Python callback instead (fmi3.py's own sequence), every logged value is the same, faults (on
    outputs, on a connection, on an unconnected Boolean input) included, and so is every clock's activation record."""
    from support import ROOT
    from tiltload.master.engine.faults.parse import load as load_faults
    from tiltload.master.engine.native import loop as native_loop
    from tiltload.master.engine.native import paths as native_paths

    runs = {}
    for path in ("kernel", "python"):
        if path == "python":
            for module in (native_loop, native_paths):  # the plan and what it says of each instance
                monkeypatch.setattr(module, "kernel_calls_fmi3", lambda slave: False)
        system = default_system(fmi3_set, "zse", 1, "mixed", seed=2, fmi=3, clocked=clocked)
        system.faults = load_faults(ROOT / "docs" / "faults" / f"{fault}.json")
        rec = RecordAll()
        ex = Execution(system, [rec])
        ex.instantiate()
        try:
            assert [bool(c.fmi3) for c in ex.loop.instances] == [path == "kernel"] * len(system.instances)
            assert [bool(c.clocks) for c in ex.loop.instances] == [path == "kernel" and clocked and i.name in ("sensors", "controller")
                                                                    for i in system.instances]
            ex.run(stop)
            activations = {name: getattr(inst, "activations", None) for name, inst in ex.instances.items()}
        finally:
            ex.close()
        runs[path] = rec.rows, activations
    assert runs["kernel"] == runs["python"] and len(runs["kernel"][0]) > 3000


def test_in_process_clocked_fmus_are_stepped_by_the_kernel_and_hosted_ones_by_the_callback(fmi3_set, monkeypatch):
    """The loop says which path each instance takes, and does take it: with the slaves' own Python step disabled
    here, the in-process FMUs (plain and clocked) still run; the controller in a worker process is stepped there (its
    callback, a message to the worker, until the first call of the loop takes the shared-memory link); asked to, the
    loop steps an in-process clocked FMU through the callback."""
    from tiltload.master.engine.fmi.fmi3 import Fmu3Slave
    from tiltload.master.engine.native.loop import NativeLoop

    system = default_system(fmi3_set, "zse", 1, "mixed", fmi=3, clocked=True)
    metrics = loop_metrics()
    ex = Execution(system, [metrics], isolate=lambda fmu, md: "Controller" in fmu.name)
    try:
        ex.instantiate()
        assert ex.loop.paths == {"scenario": "kernel: FMI 3.0", "sensors": "kernel: FMI 3.0 with clocks",
                                 "controller": "callback: worker process", "plant": "kernel: FMI 3.0"}

        def python_step(self, t, h):
            raise AssertionError(f"{self.name} stepped from Python at t={t}")
        with monkeypatch.context() as m:
            m.setattr(Fmu3Slave, "do_step", python_step)
            ex.run(0.6)
        assert ex.loop.paths["controller"] == "kernel: shared memory (worker process)"
        assert ex.instances["sensors"].activations["gps_clock"] == [0, 10, 20, 30, 40]  # the kernel's, handed back
        ex.loop = NativeLoop(ex, by_callback={"sensors"})
        assert ex.loop.paths["sensors"] == "callback: asked for" and not ex.loop.instances[1].clocks
        ex.run(1.2)  # the same slave continues through fmi3.py's sequence: its state was handed back after each call
        assert ex.instances["sensors"].activations["gps_clock"] == list(range(0, 100, 10))
    finally:
        ex.close()
    assert metrics.table() == _metrics(default_system(fmi3_set, "zse", 1, "mixed", fmi=3), 1.2)


def test_restart_on_the_same_instances_repeats_the_run(fmi3_set):
    """Campaigns run many runs on one set of instances: fmi3Reset, then initialization again."""
    system = default_system(fmi3_set, "zse", 1, "mixed", fmi=3, clocked=True)
    metrics = [loop_metrics(), loop_metrics()]
    ex = Execution(system, [metrics[0]])
    try:
        ex.instantiate()
        ex.run(1.2)
        ex.restart(observers=[metrics[1]])
        ex.run(1.2)
        assert ex.instances["sensors"].activations["gps_clock"] == [0, 10, 20, 30, 40, 50, 60, 70, 80, 90]
    finally:
        ex.close()
    assert metrics[0].table() == metrics[1].table()


# ---- the clocks in the log ---------------------------------------------------------------------------------------
def test_log_shows_each_clocked_group_sampled_exactly_at_its_clock_ticks(fmi3_set, tmp_path):
    system = default_system(fmi3_set, "zse", 1, "mixed", fmi=3, clocked=True)
    log = tmp_path / "clocked.mcap"
    logger = McapLogger(log)
    ex = Execution(system, [logger])
    try:
        ex.instantiate()
        md = ex.model_descriptions["sensors"]
        ex.run(3.0)
        activations = ex.instances["sensors"].activations
        control = ex.instances["controller"].activations
    finally:
        ex.close()
    ticks = round(3.0 / T)
    period = {k.name: round(k.interval / T) for k in md.clocks}
    assert period == {f"{g.name}_clock": round(g.period / T) for g in GROUPS} and period["gps_clock"] == 10
    for g in GROUPS:  # the master activated each clock exactly at its ticks
        assert activations[f"{g.name}_clock"] == list(range(0, ticks, period[f"{g.name}_clock"]))
    assert control["control_clock"] == list(range(ticks))
    messages = read(log, ["/sensors"])["/sensors"]  # sampled at its steps' start (timing "sample"): one a step from 0
    assert len(messages) == ticks
    k = np.round(np.array([m["t"] for m in messages]) / T).astype(int)
    assert np.array_equal(k, np.arange(ticks))
    for g in GROUPS:
        n = period[f"{g.name}_clock"]
        flags = np.array([m[f"{g.name}_new"] for m in messages])
        assert np.array_equal(flags, k % n == 0), g.name  # sampled exactly at its clock's ticks
        for name in channel_names(g):
            if name.startswith("lkf_") and name[4:] not in ("x", "y", "z"):
                continue  # q's angles carry no noise (bound 0): they may repeat
            held = np.array([m[name] for m in messages])
            changed = np.flatnonzero(np.diff(held)) + 1
            assert set(changed) <= set(np.flatnonzero(k % n == 0)), name  # held in between
            assert len(changed) >= (ticks // n) - 2, name  # and new (noisy) at the ticks


# ---- the schedule --------------------------------------------------------------------------------------------------
def test_clocks_replace_the_period_and_must_sit_on_the_tick(fmi3_set, fmus, tmp_path):
    system = default_system(fmi3_set, "zse", 1, "mixed", fmi=3, clocked=True)
    ex = Execution(system)
    assert ex.every == {"scenario": 1, "sensors": 1, "controller": 1, "plant": 1}
    system.instance("sensors").period = 0.024
    with pytest.raises(DescriptionError, match="has clocks .* which replace period: remove the period"):
        Execution(system)
    system.instance("sensors").period = None
    system.tick = 0.005
    with pytest.raises(DescriptionError, match="clock lkf_clock .* is not on the 0.005 s tick"):
        Execution(system)
    system.tick = 0.006  # every clock a whole number of 6 ms ticks: the clocked FMUs step every other tick
    assert Execution(system).every == {"scenario": 1, "sensors": 2, "controller": 2, "plant": 1}
    wrong = default_system(fmus, "zse", 1, "mixed", fmi=3)
    with pytest.raises(DescriptionError, match="the system description says FMI 3, but TiltloadScenario.fmu is FMI 2.0"):
        Execution(wrong)


def test_a_json_system_names_an_instance_fmi_version(fmi3_set, tmp_path):
    reference = default_system(fmi3_set, "zse", 1, "mixed", fmi=3, clocked=True)
    reference.instance("plant").fmi = None  # naming the version is optional
    path = sysdesc.save(reference, tmp_path / "clocked.json")
    data = json.loads(path.read_text())
    assert [i.get("fmi") for i in data["instances"]] == [3, 3, 3, None]
    system = sysdesc.load(path)
    assert [i.fmi for i in system.instances] == [3, 3, 3, None]
    assert _metrics(system, 2.0) == _metrics(reference, 2.0)
    data["instances"][0]["fmi"] = 4
    path.write_text(json.dumps(data))
    with pytest.raises(DescriptionError, match="instances.0.fmi"):
        sysdesc.load(path)


# ---- a snapshot ------------------------------------------------------------------------------------------------------
@pytest.mark.slow
def test_state_saved_at_20_s_continues_bit_for_bit_in_new_instances(fmi3_set, tmp_path):
    """A snapshot at 20 s (every FMU's fmi3SerializeFMUState, the slaves' held clocked outputs, the master's state),
    written to a file, read back and restored into a new set of instances, continues the clocked loop through the C
    tick loop exactly as the uninterrupted run does."""
    from tiltload.master.engine import snapshot

    system = default_system(fmi3_set, "zse", 1, "mixed", fmi=3, clocked=True)
    at, end = round(20.0 / T), round(22.0 / T)
    whole = Record()
    ex = Execution(system, [whole])
    try:
        ex.instantiate()
        ex.run(at * T)
        path = snapshot.write(snapshot.take(ex), tmp_path / "at20.snapshot")
        mark = {name: len(rows) for name, rows in whole.rows.items()}
        ex.run(end * T)
    finally:
        ex.close()
    again = Record()
    ex = Execution(default_system(fmi3_set, "zse", 1, "mixed", fmi=3, clocked=True), [again])
    try:
        ex.instantiate(resume=snapshot.read(path))  # new instances, initialized at t = 0, then the saved states
        assert ex.ticks_done == at
        ex.run(end * T)
    finally:
        ex.close()
    for name, rows in again.rows.items():
        assert np.array_equal(np.array(rows), np.array(whole.rows[name][mark[name]:])), name
    assert len(again.rows["plant"]) == end - at and np.ptp(np.array(again.rows["plant"])[:, 0]) > 0.01


def test_a_damaged_fmi3_state_is_refused_in_one_line(fmi3_set):
    system = default_system(fmi3_set, "zse", 1, "mixed", fmi=3, clocked=True)
    ex = Execution(system, [])
    try:
        ex.instantiate()
        sensors = ex.instances["sensors"]
        good = sensors.get_state()
        for bad, why in ((b"x" * len(good), "not an FMI 3.0 slave's state"), (good[:-3], "does not match its header")):
            with pytest.raises(ExecutionError, match=f"sensors: cannot restore its state: .*{why}"):
                sensors.set_state(bad)
        sensors.set_state(good)
    finally:
        ex.close()


# ---- other importers ---------------------------------------------------------------------------------------------------
@pytest.mark.slow
def test_fmpy_steps_the_plain_fmi3_loop_as_our_master_does(fmi3_set):
    """FMPy's FMU3Slave wrapper, driven by a few lines here in the loop's order (set the inputs from the latest outputs,
    doStep, get), gives our master's plant trajectory bit for bit."""
    system = default_system(fmi3_set, "fsi", 1, "mixed", fmi=3)
    mds = {i.name: read_fmu(i.fmu, i.name) for i in system.instances}
    links = connections.resolve(system, mds)
    ticks = round(3.0 / T)
    sessions = {}
    try:
        for inst in system.instances:
            s = sessions[inst.name] = Session3(inst.fmu, instance=inst.name)
            s.set(**inst.parameters)
        outputs = {}
        for name, s in sessions.items():
            s.fmu.exitInitializationMode()
            outputs[name] = {v.valueReference: v for v in s.md.modelVariables if v.causality == "output"}
        latest = {(name, vr): s.fmu.getFloat64([vr])[0] if v.type == "Float64" else s.fmu.getBoolean([vr])[0]
                  for name, s in sessions.items() for vr, v in outputs[name].items() if v.type in ("Float64", "Boolean")}
        trajectory = []
        for k in range(ticks):
            for inst in system.instances:
                s = sessions[inst.name]
                for link in (x for x in links if x.target == inst.name):
                    value = latest[link.source, link.source_vr]
                    (s.fmu.setFloat64 if link.type == "Real" else s.fmu.setBoolean)([link.target_vr], [value])
                assert s.do_step(k * T, T)[0] == 0
                for vr, v in outputs[inst.name].items():
                    if v.type in ("Float64", "Boolean"):
                        latest[inst.name, vr] = (s.fmu.getFloat64 if v.type == "Float64" else s.fmu.getBoolean)([vr])[0]
            trajectory.append(sessions["plant"].reals(*STATE_NAMES))
    finally:
        for s in sessions.values():
            s.close()
    rec = Record()
    _run(system, ticks * T, [rec])
    plant = read_fmu(fmi3_set / "TiltloadPlant.fmu", "plant")
    index = [[v.name for v in plant.modelVariables if v.causality == "output" and v.type == "Real"].index(n) for n in STATE_NAMES]
    assert np.array_equal(np.array(trajectory), np.array(rec.rows["plant"])[:, index])


def test_a_c_host_written_from_the_standard_runs_the_clocked_loop_as_our_master_does(fmi3_set, tmp_path):
    system = default_system(fmi3_set, "zse", 1, "mixed", seed=2, fmi=3, clocked=True)
    ticks = round(5.0 / T)
    plan = host_plan(system, tmp_path, ticks, [("plant", n) for n in STATE_NAMES])
    host = tmp_path / "fmi3_loop_host"
    subprocess.run(["cc", "-std=c11", "-Wall", "-Wextra", "-Werror", f"-I{fmi_header_dir(3)}", str(HOSTS / "fmi3_loop_host.c"),
                    "-o", str(host), "-ldl", "-lm"], check=True)
    proc = subprocess.run(["env", "-i", str(host), str(plan)], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    rows = [line.split() for line in proc.stdout.splitlines() if " plant " in line]
    c_host = np.array([float.fromhex(r[3]) for r in rows]).reshape(ticks, len(STATE_NAMES))
    rec = Record()
    _run(system, ticks * T, [rec])
    plant = read_fmu(fmi3_set / "TiltloadPlant.fmu", "plant")
    names = [v.name for v in plant.modelVariables if v.causality == "output" and v.type == "Real"]
    ours = np.array(rec.rows["plant"])[:, [names.index(n) for n in STATE_NAMES]]
    assert np.array_equal(c_host, ours)
    assert abs(ours[-1, 0] - 2 * np.cos(np.pi * 5.0 / 20)) < 0.5  # on its way round the circle


@pytest.mark.slow
def test_the_clocked_loop_is_clean_under_address_and_undefined_behaviour_sanitizers(fmi3_set, tmp_path):
    """The clocked FMUs rebuilt from their sources/ (the files buildDescription.xml lists) with ASan and UBSan, the C
    host too: 2 s of the clocked loop with no finding (the plain FMUs' layer path is the FMI 2.0 tests' ASan run's)."""
    system = default_system(fmi3_set, "zse", 1, "mixed", fmi=3, clocked=True)
    plan = host_plan(system, tmp_path, round(2.0 / T), [("plant", n) for n in STATE_NAMES])
    sanitize = ["-fsanitize=address,undefined", "-fno-omit-frame-pointer", "-fno-sanitize-recover=undefined", "-g"]
    lines = plan.read_text().splitlines()
    for i, line in enumerate(lines):
        if not line.startswith("F "):
            continue
        _, name, _, token = line.split()
        if name not in ("sensors", "controller"):  # the clocked ones
            continue
        src = tmp_path / name / "sources"
        listed = [e.get("name") for e in ET.parse(src / "buildDescription.xml").iter("SourceFile")]
        rebuilt = tmp_path / f"{name}_asan.so"
        subprocess.run(["cc", "-std=c11", "-O1", "-fPIC", "-shared", *sanitize, "-DCASADI_SYMBOL_EXPORT=", f"-I{src}",
                        f"-I{fmi_header_dir(3)}", *(str(src / f) for f in listed), "-o", str(rebuilt), "-lm"], check=True)
        lines[i] = f"F {name} {rebuilt} {token}"
    plan.write_text("\n".join(lines) + "\n")
    host = tmp_path / "host_asan"
    subprocess.run(["cc", "-std=c11", *sanitize, f"-I{fmi_header_dir(3)}", str(HOSTS / "fmi3_loop_host.c"), "-o", str(host),
                    "-ldl", "-lm"], check=True)
    proc = subprocess.run(["env", "-i", "ASAN_OPTIONS=detect_leaks=1", str(host), str(plan)], capture_output=True, text=True,
                          timeout=600)
    assert proc.returncode == 0, proc.stdout[-1000:] + proc.stderr[-3000:]
    assert "runtime error" not in proc.stderr and "AddressSanitizer" not in proc.stderr and "LeakSanitizer" not in proc.stderr


def test_a_scheduled_execution_slave_takes_its_own_kernel_path():
    """It is an Fmu3Slave (it reuses the clocked slave's staging) but runs partitions, no Event Mode and no step: the
    kernel must not take it for a clocked co-simulation FMU, and says so in its path."""
    from tiltload.master.engine.fmi.fmi3 import Fmu3Slave
    from tiltload.master.engine.fmi.fmi3_scheduled import Fmu3ScheduledSlave
    from tiltload.master.engine.native.loop import path_of

    scheduled, clocked = object.__new__(Fmu3ScheduledSlave), object.__new__(Fmu3Slave)
    scheduled.clocked = clocked.clocked = True
    scheduled.api = clocked.api = {}  # every variable of the kernel's types (Float64, Int32, Boolean)
    assert path_of(scheduled) == "kernel: FMI 3.0 Scheduled Execution"
    assert path_of(clocked) == "kernel: FMI 3.0 with clocks"
    clocked.api = {("Real", 7): "Float32"}  # a Float32 variable: the callback converts it
    assert path_of(clocked) == "callback: FMI 3.0 types the kernel does not convert"


def test_the_kernel_s_event_mode_makes_the_calls_fmi3_py_makes(tmp_path, monkeypatch):
    """A clocked FMU that logs every call (support/fmi3_trace_fmu.py: a discrete input, two clocks with a shift, events
    asked by the step and by a next event time, a second update): the C loop's Event Mode and fmi3.py's sequence
    (forced through the callback) make the same calls with the same values, step after step, and the FMU refuses
    none. The trace has what the thesis's FMUs never make: events with no clock due, steps with no event, a
    second fmi3UpdateDiscreteStates."""
    import re

    from support.fmi3_trace_fmu import TICK, trace_fmu
    from tiltload.master.engine.native import loop as native_loop
    from tiltload.master.engine.native import paths as native_paths

    fmu = trace_fmu(tmp_path)
    runs = {}
    for path in ("kernel", "python"):
        if path == "python":
            for module in (native_loop, native_paths):  # the plan and what it says of each instance
                monkeypatch.setattr(module, "kernel_calls_fmi3", lambda slave: False)
        system = sysdesc.System(TICK, [sysdesc.Instance("src", fmu), sysdesc.Instance("dut", fmu)], auto_connect=False,
                                connections=[sysdesc.Connection("src.y_a", "dut.u_c"), sysdesc.Connection("src.y", "dut.u_a"),
                                             sysdesc.Connection("src.n_b", "dut.u_d", delay=1),
                                             sysdesc.Connection("src.f", "dut.b_b")])
        rec = RecordAll()
        ex = Execution(system, [rec])
        ex.instantiate()
        try:
            assert list(ex.loop.paths.values()) == ["kernel: FMI 3.0 with clocks" if path == "kernel" else "callback: Fmu3Slave"] * 2
            ex.run(1.2)
            runs[path] = rec.rows, {n: (list(i.log), i.activations) for n, i in ex.instances.items()}
        finally:
            ex.close()
    assert runs["kernel"] == runs["python"]
    log = runs["kernel"][1]["dut"][0]
    assert not [line for line in log if line.startswith("refused")] and len(runs["kernel"][0]) == 2 * 120
    assert runs["kernel"][1]["dut"][1] == {"a": list(range(0, 120, 2)), "b": list(range(1, 120, 3))}
    calls = " ".join(line.split(" ", 1)[0] for line in log)
    assert re.search(r"enterEventMode (set\w+ |getBoolean )*updateDiscreteStates", calls)  # an event with no clock due
    assert re.search(r"doStep (set\w+ |get\w+ )*doStep", calls)  # a step with no event
    assert any("update 2" in line for line in log)

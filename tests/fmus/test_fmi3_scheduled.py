"""The controller as an FMI 3.0 Scheduled Execution FMU (TiltloadControllerSE): what it declares (a partition per
estimator correction at its sensor group's period, the law's at T_c, priorities), the refusals of
fmi3ActivateModelPartition (a wrong clock, a time off its grid or not increasing, the law before a correction of its
instant), and a second importer, the C host hosts/fmi3_se_host.c written from the standard: its scheduler runs the SE
controller in the loop with the plant, sensor and scenario FMUs, and the plant's trajectory equals our master's with
the co-simulation clocked controller bit for bit; preempting partitions at the FMU's unlock points changes nothing."""

from __future__ import annotations

import subprocess
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi3 import FMU3ScheduledExecution
from fmpy.validation import validate_fmu
from support import HOSTS, T
from support.fmi3_plan import host_plan
from tiltload.controller_fmu.fmu.build import TC
from tiltload.master.app.loop.thesis import default_stop, default_system
from tiltload.master.app.regression.reproduce import CASES, SEED, case_name
from tiltload.master.engine.execution import Execution
from tiltload.master.engine.fmi.model_description import read_fmu
from tiltload.master.engine.observers import Observer
from tiltload.native_fmu.package import fmi_header_dir
from tiltload.plant_fmu.interface import STATE_NAMES
from tiltload.sensor_fmu.fmu_variables import channel_names
from tiltload.sensor_fmu.suite import GROUPS

COMMANDS = ("f_R", "f_L", "tau_R", "tau_L")


@pytest.fixture(scope="module")
def host(tmp_path_factory) -> Path:
    exe = tmp_path_factory.mktemp("se_host") / "fmi3_se_host"
    subprocess.run(["cc", "-std=c11", "-O2", "-Wall", "-Wextra", "-Werror", f"-I{fmi_header_dir(3)}",
                    str(HOSTS / "fmi3_se_host.c"), "-o", str(exe), "-ldl", "-lm"], check=True)
    return exe


def _root(fmu: Path) -> ET.Element:
    with zipfile.ZipFile(fmu) as z:
        return ET.fromstring(z.read("modelDescription.xml"))


# ---- what it declares --------------------------------------------------------------------------------------------
def test_fmpy_validates_the_se_controller_with_no_problem(se_fmu):
    assert validate_fmu(str(se_fmu)) == []
    proc = subprocess.run(["fmpy", "validate", str(se_fmu)], capture_output=True, text=True)  # the command line, too
    assert proc.returncode == 0 and "No problems found" in proc.stdout
    root = _root(se_fmu)
    assert root.find("ScheduledExecution") is not None and root.find("CoSimulation") is None


def test_a_partition_per_correction_at_its_sensor_period_and_the_law_ranked_below_them(se_fmu):
    """Table 5.8's groups (the sensor suite's table, not the controller's): each group the estimators read has a
    partition at its period; among them the shorter period has the higher priority (rate-monotonic), and the law at
    T_c, which reads them all at its instant, comes after every one."""
    clocks = {e.get("name"): e for e in _root(se_fmu).iter("Clock")}
    groups = [g for g in GROUPS if g.source == "pi" or g.name == "lkf"]
    assert set(clocks) == {f"{g.name}_clock" for g in groups} | {"control_clock"}
    prio = {n: int(e.get("priority")) for n, e in clocks.items()}
    for g in groups:
        assert float(clocks[f"{g.name}_clock"].get("intervalDecimal")) == g.period
        for h in groups:
            if g.period < h.period:
                assert prio[f"{g.name}_clock"] < prio[f"{h.name}_clock"]
            if g.period == h.period:
                assert prio[f"{g.name}_clock"] == prio[f"{h.name}_clock"]
    assert float(clocks["control_clock"].get("intervalDecimal")) == TC
    assert prio["control_clock"] > max(prio[f"{g.name}_clock"] for g in groups)
    md = read_model_description(str(se_fmu))
    clock_of = {v.name: [k.name for k in v.clocks] for v in md.modelVariables if v.causality in ("input", "output")
                and v.type != "Clock"}
    for g in groups:
        names = [f"lkf_{n}" for n in ("x", "y", "z")] if g.name == "lkf" else [*channel_names(g), f"{g.name}_new"]
        assert all(clock_of[n] == [f"{g.name}_clock"] for n in names), g.name
    assert all(clock_of[n] == ["control_clock"] for n in (*COMMANDS, "x_ref", "exact_x", "est_x"))


# ---- fmi3ActivateModelPartition's refusals ---------------------------------------------------------------------
class SeSession:
    """The SE controller through FMPy's FMU3ScheduledExecution, in Clock Activation Mode, its log captured."""

    def __init__(self, fmu: Path, tmp: Path):
        self.md = read_model_description(str(fmu))
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.log: list[str] = []
        self.fmu = FMU3ScheduledExecution(guid=self.md.guid, unzipDirectory=extract(str(fmu), str(tmp)),
                                          modelIdentifier=self.md.scheduledExecution.modelIdentifier, instanceName="se")
        self.fmu.instantiate(loggingOn=True, logMessage=lambda env, status, cat, msg: self.log.append(msg.decode()))
        self.fmu.enterInitializationMode(startTime=0.0)

    def said(self, text: str) -> bool:
        return any(text in m for m in self.log)

    def refused(self, clock: str, t: float, said: str) -> None:
        with pytest.raises(FMICallException):
            self.fmu.activateModelPartition(self.vr[clock], t)
        assert self.said(said), self.log[-3:]


def _corrections(s: SeSession) -> list[str]:
    return [v.name for v in s.md.modelVariables if v.type == "Clock" and v.name != "control_clock"]


@pytest.mark.parametrize("case", ["off_grid", "slow_clock", "not_a_clock", "again", "law_first", "wrong_mode"])
def test_a_partition_activated_at_the_wrong_clock_or_time_is_an_error(se_fmu, tmp_path, case):
    s = SeSession(se_fmu, tmp_path)
    if case == "wrong_mode":  # still in Initialization Mode
        s.refused("control_clock", 0.0, "fmi3ActivateModelPartition is not allowed in initialization mode")
        return
    s.fmu.exitInitializationMode()
    if case == "off_grid":
        s.refused("baro_clock", 0.006, "t=0.006 s is not an activation time of baro_clock (every 0.012 s from 0 s)")
    elif case == "slow_clock":  # on T_c's grid, not on the GPS's 120 ms one
        s.refused("gps_clock", 0.012, "t=0.012 s is not an activation time of gps_clock")
    elif case == "not_a_clock":
        s.refused("f_R", 0.0, f"value reference {s.vr['f_R']} is not a clock of TiltloadController")
    elif case == "again":
        s.fmu.activateModelPartition(s.vr["baro_clock"], 0.0)
        s.refused("baro_clock", 0.0, "baro_clock activated at t=0 s, but its last activation was at t=0 s")
    elif case == "law_first":  # every correction of t = 0 but the GPS's
        for name in _corrections(s):
            if name != "gps_clock":
                s.fmu.activateModelPartition(s.vr[name], 0.0)
        s.refused("control_clock", 0.0, "the law at t=0 s needs the gps_clock correction of the same instant first")
    # after an error the instance is Terminated: no partition runs any more
    with pytest.raises(FMICallException):
        s.fmu.activateModelPartition(s.vr["control_clock"], T)
    assert s.said("fmi3ActivateModelPartition is not allowed in terminated")


def test_the_se_controller_refuses_co_simulation(se_fmu, fmi3_set, tmp_path):
    from fmpy.fmi3 import FMU3Slave

    md = read_model_description(str(se_fmu))
    log = []
    slave = FMU3Slave(guid=md.guid, unzipDirectory=extract(str(se_fmu), str(tmp_path)),
                      modelIdentifier=md.scheduledExecution.modelIdentifier, instanceName="cs")
    with pytest.raises(Exception, match="Failed to instantiate"):
        slave.instantiate(logMessage=lambda env, status, cat, msg: log.append(msg.decode()))
    assert any("is a Scheduled Execution FMU only (fmi3InstantiateScheduledExecution)" in m for m in log)


# ---- our master as its scheduler: the C tick loop's path (tl_loop.c) and the Python one (fmi3_scheduled.py) ----------
def _se_system(folder: Path, se_fmu: Path, case=("zse", 1, "mixed")):
    system = default_system(folder, *case, SEED, fmi=3, clocked=True)
    system.instance("controller").fmu = se_fmu
    return system


def _se_run(system, ticks: int, path: str, before=lambda ex: None):
    """Our master with the SE controller, scheduled by the C tick loop ("kernel") or through its Python callback
    ("python"): every instance's Real outputs after every step, the activations, the lock count, the paths."""
    from tiltload.master.engine.native.loop import NativeLoop

    rec = Record()
    ex = Execution(system, [rec])
    try:
        ex.instantiate()
        if path == "python":
            ex.loop = NativeLoop(ex, by_callback={"controller"})
        before(ex)
        ex.run(ticks * T)
        slave = ex.instances["controller"]
        return rec.rows, dict(slave.activations), slave.locks, dict(ex.loop.paths)
    finally:
        ex.close()


def _same_three_ways(folder: Path, se_fmu: Path, case, ticks: int) -> dict:
    """The SE controller on the C path and on the Python path against the clocked co-simulation controller: the plant's
    20 states at every tick; the two SE paths: every instance's outputs, the activations, the lock callbacks."""
    kernel = _se_run(_se_system(folder, se_fmu, case), ticks, "kernel")
    python = _se_run(_se_system(folder, se_fmu, case), ticks, "python")
    assert kernel[3]["controller"] == "kernel: FMI 3.0 Scheduled Execution"
    assert python[3]["controller"] == "callback: asked for"
    md = read_fmu(folder / "TiltloadPlant.fmu", "plant")
    outputs = [v.name for v in md.modelVariables if v.causality == "output" and v.type == "Real"]
    states = np.array(kernel[0]["plant"])[:, [outputs.index(n) for n in STATE_NAMES]]
    assert np.array_equal(states, _ours(default_system(folder, *case, SEED, fmi=3, clocked=True), ticks, folder))
    for name, rows in kernel[0].items():
        assert np.array_equal(np.array(rows), np.array(python[0][name])), name
    assert kernel[1:3] == python[1:3]
    return kernel[1]


def test_our_master_schedules_the_se_controller_on_both_paths_as_it_runs_the_clocked_one_bit_for_bit(fmi3_set, se_fmu):
    """The loop with the SE controller in place of the clocked one, its partitions activated by the C tick loop and by
    the Python path: the plant's trajectory the clocked run's bits; each partition activated exactly at its clock's
    ticks (the GPS every 10th, the camera every 2nd, the law every tick); the lock callbacks called alike."""
    ticks = round(2.0 / T)
    activations = _same_three_ways(fmi3_set, se_fmu, ("zse", 1, "mixed"), ticks)
    every = {"gps_clock": 10, "cam_xy_clock": 2, "cam_z_clock": 2, "control_clock": 1, "baro_clock": 1}
    for clock, n in every.items():
        assert activations[clock] == list(range(0, ticks, n)), clock


@pytest.mark.slow
@pytest.mark.parametrize("case", CASES, ids=[case_name(*c) for c in CASES])
def test_the_twelve_cases_with_the_se_controller_on_both_paths_equal_the_clocked_runs_bit_for_bit(fmi3_set, se_fmu, case):
    """Every reproduction case at its full length (the thesis's ch. 5), seed 1."""
    _same_three_ways(fmi3_set, se_fmu, case, round(default_stop(case[1]) / T))


def _failure(fmi3_set, se_fmu, path: str, before) -> str:
    from tiltload.master.engine.errors import ExecutionError

    with pytest.raises(ExecutionError) as caught:
        _se_run(_se_system(fmi3_set, se_fmu), 3, path, before)
    return str(caught.value)


def test_a_refused_activation_ends_the_run_in_the_same_line_on_both_paths(fmi3_set, se_fmu):
    """The GPS partition activated at t = 0 before the run: the loop's own activation at t = 0 is a repeat, which the
    FMU refuses (fmi3Error); the C loop stops with the line the Python path says, the FMU's reason in it."""
    def activate_gps(ex) -> None:
        slave = ex.instances["controller"]
        gps = next(k for k in slave.clocks if k.name == "gps_clock")
        assert slave._activate(slave.component, gps.value_reference, 0.0) == 0

    kernel = _failure(fmi3_set, se_fmu, "kernel", activate_gps)
    assert kernel == _failure(fmi3_set, se_fmu, "python", activate_gps)
    assert kernel.startswith("controller: activateModelPartition(gps_clock) at t=0 s failed (")
    assert "\n" not in kernel


def test_a_partition_returning_with_a_lock_held_ends_the_run_on_both_paths(fmi3_set, se_fmu):
    """One lock counted as held before the run (as a partition that locked and never unlocked would leave it): the
    first partition to return is caught, in the same line on both paths."""
    def hold_a_lock(ex) -> None:
        ex.instances["controller"].lock_depth.value = 1

    kernel = _failure(fmi3_set, se_fmu, "kernel", hold_a_lock)
    assert kernel == _failure(fmi3_set, se_fmu, "python", hold_a_lock)
    first = min(read_fmu(se_fmu, "controller").clocks, key=lambda k: k.priority).name  # ties: the first declared
    assert kernel == f"controller: partition {first} returned at t=0 s with 1 preemption lock(s) held"


def test_a_restart_after_a_run_ended_by_a_held_lock_holds_none(fmi3_set, se_fmu):
    """The lock count belongs to a run: after one ended by a lock held, Execution.restart (fmi3Reset, initialization)
    starts the next with none, on both paths, and it runs."""
    from tiltload.master.engine.errors import ExecutionError
    from tiltload.master.engine.native.loop import NativeLoop

    for path in ("kernel", "python"):
        ex = Execution(_se_system(fmi3_set, se_fmu), [])
        try:
            ex.instantiate()
            if path == "python":
                ex.loop = NativeLoop(ex, by_callback={"controller"})
            ex.instances["controller"].lock_depth.value = 1
            with pytest.raises(ExecutionError, match="preemption lock"):
                ex.run(3 * T)
            ex.restart()
            ex.run(3 * T)
            assert ex.time == pytest.approx(3 * T) and ex.instances["controller"].lock_depth.value == 0
        finally:
            ex.close()


def test_a_se_fmu_runs_in_this_process_or_a_worker_not_on_a_server(se_fmu):
    from tiltload.master.engine.errors import ExecutionError
    from tiltload.master.engine.isolation.hosting import slave_for
    from tiltload.master.engine.system import Instance

    md = read_fmu(se_fmu, "controller")  # the engine reads it: its clocks with their priorities
    assert {k.name: k.priority for k in md.clocks}["control_clock"] == max(k.priority for k in md.clocks)
    with pytest.raises(ExecutionError, match="is a Scheduled Execution FMU, which runs in this process or a worker process "
                                             "of its own, not on a tiltload serve"):
        slave_for(Instance("controller", se_fmu, remote="127.0.0.1:1", token_file="t"), md, tick=T)


# ---- the C host -----------------------------------------------------------------------------------------------------
class Record(Observer):
    def __init__(self) -> None:
        self.rows: dict[str, list[np.ndarray]] = {}

    def on_step(self, instance, t) -> None:
        self.rows.setdefault(instance.name, []).append(instance.values["Real"].copy())


def _ours(system, ticks: int, folder: Path, instance: str = "plant", names=STATE_NAMES) -> np.ndarray:
    """Our master on the co-simulation clocked controller: the instance's named Real outputs after every step."""
    rec = Record()
    ex = Execution(system, [rec])
    try:
        ex.instantiate()
        ex.run(ticks * T)
    finally:
        ex.close()
    md = read_fmu(next(i.fmu for i in system.instances if i.name == instance), instance)
    outputs = [v.name for v in md.modelVariables if v.causality == "output" and v.type == "Real"]
    return np.array(rec.rows[instance])[:, [outputs.index(n) for n in names]]


def _host(host: Path, plan: Path, *args: str) -> tuple[subprocess.CompletedProcess, dict[str, np.ndarray]]:
    proc = subprocess.run(["env", "-i", str(host), str(plan), *args], capture_output=True, text=True, timeout=600)
    by: dict[str, list[float]] = {}
    for line in proc.stdout.splitlines():
        parts = line.split()
        if len(parts) == 4 and parts[0].isdigit():
            by.setdefault(parts[1], []).append(float.fromhex(parts[3]))
    return proc, {k: np.array(v) for k, v in by.items()}


def _compare(fmi3_set, se_fmu, host, tmp_path, case, seconds) -> None:
    system = default_system(fmi3_set, *case, SEED, fmi=3, clocked=True)
    ticks = round(seconds / T)
    plan = host_plan(system, tmp_path, ticks, [("plant", n) for n in STATE_NAMES], scheduled={"controller": se_fmu})
    proc, rows = _host(host, plan)
    assert proc.returncode == 0, proc.stdout[-500:] + proc.stderr[-2000:]
    c_host = rows["plant"].reshape(ticks, len(STATE_NAMES))
    assert np.array_equal(c_host, _ours(system, ticks, fmi3_set)), case_name(*case)  # the same bits


def test_the_c_host_runs_the_se_controller_as_our_master_runs_the_clocked_one_bit_for_bit(fmi3_set, se_fmu, host, tmp_path):
    """The nominal case (ZSE, trajectory 1, mixed H2/Hinf), 2 s: the plant's 20 states at every tick."""
    _compare(fmi3_set, se_fmu, host, tmp_path, ("zse", 1, "mixed"), 2.0)


@pytest.mark.slow
@pytest.mark.parametrize("case", CASES, ids=[case_name(*c) for c in CASES])
def test_the_twelve_cases_on_the_c_host_equal_our_clocked_runs_bit_for_bit(fmi3_set, se_fmu, host, tmp_path, case):
    """Every reproduction case at its full length (the thesis's ch. 5), seed 1."""
    _compare(fmi3_set, se_fmu, host, tmp_path, case, default_stop(case[1]))


def test_plain_rate_monotonic_order_runs_the_law_first_and_the_fmu_refuses(fmi3_set, se_fmu, host, tmp_path):
    """By period alone the law (12 ms) would run before the camera (24 ms) and GPS (120 ms) corrections of its own
    instant; the host's rule that a partition ranks below those it reads gives the FMU's declared order, and without
    it the FMU refuses the law rather than run it on last period's samples."""
    system = default_system(fmi3_set, "zse", 1, "mixed", SEED, fmi=3, clocked=True)
    plan = host_plan(system, tmp_path, 3, [], scheduled={"controller": se_fmu})
    proc, _ = _host(host, plan)
    assert proc.returncode == 0 and "MISMATCH" not in proc.stderr, proc.stderr
    proc, _ = _host(host, plan, "--rate-monotonic-only")
    assert proc.returncode == 1
    assert "the law at t=0 s needs the gps_clock correction of the same instant first" in proc.stderr


def test_a_partition_activated_again_while_it_runs_is_refused_with_a_logged_line(fmi3_set, se_fmu, host, tmp_path):
    """docs/fmi3.md: the host activates the running partition again, at the instant it is running for, from the
    partition's own unlock callback (as a scheduler that lost track of it would). The FMU refuses with fmi3Error and
    logs why, and the host's run ends there (Terminated), instead of the partition running on its half-written state."""
    system = default_system(fmi3_set, "zse", 1, "mixed", SEED, fmi=3, clocked=True)
    plan = host_plan(system, tmp_path, 3, [], scheduled={"controller": se_fmu})
    proc, _ = _host(host, plan, "--reactivate")
    assert proc.returncode == 1, proc.stderr[-2000:]
    assert "from its unlock callback: refused with fmi3Error" in proc.stderr, proc.stderr[-2000:]
    assert "activated at t=0 s while its partition is still running for t=0 s" in proc.stderr, proc.stderr[-2000:]


def test_preemption_at_the_fmu_s_unlock_points_changes_no_output(fmi3_set, se_fmu, host, tmp_path):
    """The loop run records the SE controller's inputs; replayed alone, with every higher-priority partition of the next
    instant run at each preemption point of the one running (its unlock callbacks: as when a partition overruns into
    the next period), the commands and estimates equal the loop run's, tick for tick."""
    system = default_system(fmi3_set, "zse", 1, "mixed", SEED, fmi=3, clocked=True)
    outputs = [("controller", n) for n in (*COMMANDS, "est_x", "est_z", "est_d_x", "zse_G_frobenius")]
    plan = host_plan(system, tmp_path, round(3.0 / T), outputs, scheduled={"controller": se_fmu})
    recorded = tmp_path / "inputs.txt"
    loop, looped = _host(host, plan, "--record", str(recorded))
    alone, replayed = _host(host, plan, "--replay", str(recorded), "--preempt")
    assert loop.returncode == 0 and alone.returncode == 0, alone.stderr[-2000:]
    preemptions = int(alone.stdout.split("preemptions ")[1])
    assert preemptions > round(3.0 / T)  # at least one a tick
    assert np.array_equal(looped["controller"], replayed["controller"])
    ours = _ours(system, round(3.0 / T), fmi3_set, "controller", [n for _, n in outputs])
    assert np.array_equal(looped["controller"].reshape(ours.shape), ours)  # and our clocked controller's, too


@pytest.mark.slow
def test_a_snapshot_of_the_se_controller_continues_bit_for_bit_in_new_instances(fmi3_set, se_fmu, tmp_path):
    """A snapshot at 1 s (the SE FMU's serialized state: its latches and activation record), restored into new
    instances, continues as the uninterrupted run: every instance's outputs at every step."""
    from tiltload.master.engine import snapshot

    def system():
        s = default_system(fmi3_set, "zse", 1, "mixed", SEED, fmi=3, clocked=True)
        s.instance("controller").fmu = se_fmu
        return s
    at, end = round(1.0 / T), round(1.5 / T)
    whole = Record()
    ex = Execution(system(), [whole])
    try:
        ex.instantiate()
        ex.run(at * T)
        path = snapshot.write(snapshot.take(ex), tmp_path / "at1.snapshot")
        mark = {name: len(rows) for name, rows in whole.rows.items()}
        ex.run(end * T)
    finally:
        ex.close()
    again = Record()
    ex = Execution(system(), [again])
    try:
        ex.instantiate(resume=snapshot.read(path))
        ex.run(end * T)
    finally:
        ex.close()
    for name, rows in again.rows.items():
        assert np.array_equal(np.array(rows), np.array(whole.rows[name][mark[name]:])), name
    assert len(again.rows["controller"]) == end - at

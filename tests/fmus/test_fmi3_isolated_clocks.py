"""FMI 3.0 FMUs with clocks in a worker process of their own, stepped over the shared-memory link: the worker's C loop
runs a clocked controller's Event Mode, and a Scheduled Execution controller's partitions, with the kernel's own
sequence (isolation/host_plan.py). Held against the same FMU in this process (the kernel's sequence in the master) and
in a worker on its pipe (the slave's Python sequence there, fmi3.py and fmi3_scheduled.py: an implementation of its
own): the same bits at every step, through a state taken and restored and a restart, and the same line when a call
fails."""

from __future__ import annotations

import numpy as np
import pytest
from support.fmi3_misbehaving import misbehaving_fmi3
from tiltload.master.app.loop.thesis import default_system
from tiltload.master.engine.errors import ExecutionError
from tiltload.master.engine.execution import Execution
from tiltload.master.engine.isolation import hosting
from tiltload.master.engine.observers import Observer

SEED = 1
# the instance isolated, its FMU, its path in this process: the controller's one clock ticks every tick; the sensors'
# nine every 1, 2 or 10 ticks
KINDS = {"clocked controller": ("controller", "TiltloadControllerClocked.fmu", "kernel: FMI 3.0 with clocks"),
         "scheduled controller": ("controller", "TiltloadControllerSE.fmu", "kernel: FMI 3.0 Scheduled Execution"),
         "clocked sensors": ("sensors", "TiltloadSensorsClocked.fmu", "kernel: FMI 3.0 with clocks")}
# how the controller is hosted: (isolated, over shared memory); the path the loop says it takes
WAYS = {"in process": (False, False), "link": (True, True), "pipe": (True, False)}
PATHS = {"link": "kernel: shared memory (worker process)", "pipe": "callback: worker process"}


class Record(Observer):
    def __init__(self) -> None:
        self.rows: dict[str, list[np.ndarray]] = {}

    def on_step(self, instance, t) -> None:
        self.rows.setdefault(instance.name, []).append(instance.values["Real"].copy())


def _system(fmi3_set, instance: str, fmu):
    system = default_system(fmi3_set, "zse", 1, "mixed", SEED, fmi=3, clocked=True)
    system.instance(instance).fmu = fmu
    return system


def _execution(system, instance: str, way: str, observers, monkeypatch) -> Execution:
    isolated, shared = WAYS[way]
    monkeypatch.setattr(hosting, "SHARED_MEMORY", shared)
    hosted = system.instance(instance).fmu
    return Execution(system, observers, isolate=(lambda fmu, md: fmu == hosted) if isolated else None)


@pytest.mark.parametrize("kind", list(KINDS))
def test_clocked_and_scheduled_fmus_over_the_link_give_the_in_process_bits(kind, fmi3_set, monkeypatch):
    """ZSE, trajectory 1, mixed: 0.6 s, the FMU's state taken, on to 1.2 s, the state restored (its outputs those at
    0.6 s again), a restart (fmi3Reset, initialization) and 0.6 s more: every instance's outputs at every step the same
    three ways, and each way the path it says."""
    instance, fmu, in_process = KINDS[kind]
    runs = {}
    for way in WAYS:
        record = Record()
        ex = _execution(_system(fmi3_set, instance, fmi3_set / fmu), instance, way, [record], monkeypatch)
        try:
            ex.instantiate()
            ex.run(0.6)
            hosted = ex.instances[instance]
            at_06, state = hosted.values["Real"].copy(), hosted.get_state()
            ex.run(1.2)
            hosted.set_state(state)
            restored = hosted.values["Real"].copy()
            ex.restart()
            ex.run(0.6)
            runs[way] = record.rows, at_06, restored, ex.loop.paths[instance]
        finally:
            ex.close()
    assert runs["in process"][3] == in_process
    assert runs["link"][3] == PATHS["link"] and runs["pipe"][3] == PATHS["pipe"]
    ours, at_06, restored, _ = runs["in process"]
    assert np.array_equal(at_06, restored)
    assert len(ours["controller"]) == 3 * 50  # 0.6 s, 0.6 s more, 0.6 s after the restart; 12 ms a step
    for way in ("link", "pipe"):
        rows, their_06, their_restored, _ = runs[way]
        assert rows.keys() == ours.keys()
        for name in ours:
            assert np.array_equal(np.array(rows[name]), np.array(ours[name])), (way, name)
        assert np.array_equal(their_06, at_06) and np.array_equal(their_restored, restored), way


PARTITION_FAILURES = {"activate_error": "at t=0.504 s failed (error)",
                      "lock_held": "returned at t=0.504 s with 1 preemption lock(s) held"}


@pytest.fixture(scope="module")
def failing_partitions(se_fmu, tmp_path_factory):
    """The Scheduled Execution controller, foreign, its partitions from t = 0.5 s refused or returning with a preemption
    lock held (support/fmi3_misbehaving.py)."""
    return misbehaving_fmi3(se_fmu, tmp_path_factory.mktemp("partitions"), PARTITION_FAILURES, 0.5)


@pytest.mark.parametrize("mode", list(PARTITION_FAILURES))
def test_a_failing_partition_over_the_link_ends_the_run_in_the_line_the_other_ways_say(mode, failing_partitions, fmi3_set,
                                                                                       monkeypatch):
    """The host reports the kernel's failure (its kind, the clock, the status or the locks held) and the master words
    it as in process; the run stops at the same tick each way."""
    lines, steps = {}, {}
    for way in WAYS:
        record = Record()
        ex = _execution(_system(fmi3_set, "controller", failing_partitions[mode]), "controller", way, [record], monkeypatch)
        try:
            ex.instantiate()
            with pytest.raises(ExecutionError) as caught:
                ex.run(1.0)
            lines[way], steps[way] = str(caught.value), len(record.rows["plant"])
            if way != "in process":
                assert ex.loop.paths["controller"] == PATHS[way]
        finally:
            ex.close()
    assert lines["link"] == lines["in process"] == lines["pipe"], lines
    line = lines["link"]
    assert "\n" not in line and PARTITION_FAILURES[mode] in line, line
    assert line.startswith("controller: activateModelPartition(" if mode == "activate_error" else "controller: partition ")
    assert steps["link"] == steps["in process"] == steps["pipe"] == 42  # ticks 0..41 done, the failure in tick 42


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["clocked controller", "scheduled controller"])
def test_the_twelve_cases_with_the_controller_over_the_link_give_the_in_process_metrics_bit_for_bit(kind, fmi3_set):
    """Every case of `tiltload reproduce --fmi 3 --clocks` at its whole length, the controller (clocked, or Scheduled
    Execution) forced into a worker process and stepped over shared memory: every metric equal to the last bit to the
    run in process."""
    from tiltload.master.app.loop.thesis import default_stop, loop_metrics
    from tiltload.master.app.regression.reproduce import CASES
    from tiltload.master.engine.lifecycle import RunPlan, run_plan

    instance, fmu, _ = KINDS[kind]
    for case in CASES:
        results = []
        for isolate in (None, lambda path, md: path.name == fmu):
            system = default_system(fmi3_set, *case, SEED, fmi=3, clocked=True)
            system.instance(instance).fmu = fmi3_set / fmu
            results.append(run_plan(RunPlan(system, default_stop(case[1]), metrics=loop_metrics(), isolate=isolate,
                                            profile=isolate is not None)))
        here, linked = results
        assert here.error is None and linked.error is None, (case, linked.error)
        assert next(f for f in linked.profile.fmus if f.name == instance).isolated == "shared memory"  # not the pipe
        assert here.ticks == linked.ticks and here.metrics == linked.metrics, case

"""An FMU may end the run (docs/master.md, "Signals at a run's edges"): a counter built with the native FMU toolkit
(tests/support/counter_fmu) asks to terminate at a given count, FMI 2.0 (fmi2Discard with fmi2Terminated) and 3.0
(terminateSimulation from fmi3DoStep). The run ends there without an error, its last valid sample kept, and its log
equals FMPy's simulate_fmu at every time it logged, the end included; a run the counter does not end stops at the
stop time asked for (a shorter last step: the counter takes one), FMPy's last time too."""

from __future__ import annotations

import json

import numpy as np
import pytest
from fmpy import simulate_fmu
from support.counter_fmu import counter_fmu
from tiltload.master.engine.execution import Execution
from tiltload.master.engine.log import reader as log_reader
from tiltload.master.engine.log.logger import McapLogger
from tiltload.master.engine.native.loop import NativeLoop
from tiltload.master.engine.run import run_system
from tiltload.master.engine.system import Connection, Instance, System

TICK = 0.1


@pytest.fixture(scope="module", params=[2, 3], ids=["fmi2", "fmi3"])
def counter(request, tmp_path_factory):
    return request.param, counter_fmu(tmp_path_factory.mktemp(f"counter{request.param}"), request.param)


def _logged(log) -> tuple[np.ndarray, dict]:
    columns, state = log_reader.read_columns(log)
    assert state.damage is None
    t, fields = columns["/counter"]
    return np.asarray(t, dtype=float), fields


def _equals_fmpy(fmu, log, limit: int, stop: float) -> np.ndarray:
    """Our log against FMPy's result at every time we logged (FMPy's last row at a time: it samples the end twice)."""
    ref = simulate_fmu(str(fmu), stop_time=stop, output_interval=TICK, start_values={"limit": limit, "gain": 0.5})
    t, fields = _logged(log)
    assert len(np.unique(t)) == len(t)
    rows = [np.flatnonzero(np.isclose(ref["time"], s, rtol=0, atol=1e-9))[-1] for s in t]
    assert len(t) == len(np.unique(np.round(ref["time"], 9)))  # every time FMPy has, none more
    for name in ("count", "x", "y"):
        np.testing.assert_array_equal(np.asarray(fields[name]), ref[name][rows], err_msg=name)
    np.testing.assert_allclose(t, ref["time"][rows], rtol=0, atol=1e-12)
    return t


def test_an_fmu_that_ends_the_run_ends_it_there_with_its_last_sample(counter, tmp_path):
    version, fmu = counter
    system = System(TICK, [Instance("counter", fmu, parameters={"limit": 5})])
    res = run_system(system, 1.0, tmp_path / "run.mcap", progress=False)
    assert res.error is None and res.ended_by == ("counter", pytest.approx(0.5))
    assert res.sim_time == pytest.approx(0.5)
    t = _equals_fmpy(fmu, tmp_path / "run.mcap", 5, 1.0)
    assert t[-1] == pytest.approx(0.5) and _logged(tmp_path / "run.mcap")[1]["count"][-1] == 5


def test_a_run_the_fmu_does_not_end_stops_at_the_stop_time_with_a_shorter_last_step(counter, tmp_path):
    version, fmu = counter
    system = System(TICK, [Instance("counter", fmu, parameters={"limit": 100})])
    res = run_system(system, 0.25, tmp_path / "run.mcap", progress=False)
    assert res.error is None and res.ended_by is None and res.sim_time == 0.25
    t = _equals_fmpy(fmu, tmp_path / "run.mcap", 100, 0.25)
    assert t[-1] == 0.25 and len(t) == 4


def test_the_python_stepped_path_ends_the_run_the_same_way(counter, tmp_path):
    """The same counter stepped through the loop's Python callback (the path of a slave the kernel cannot call)."""
    version, fmu = counter
    system = System(TICK, [Instance("counter", fmu, parameters={"limit": 3})])
    ex = Execution(system, [McapLogger(tmp_path / "cb.mcap")])
    ex.instantiate()
    ex.loop = NativeLoop(ex, by_callback=frozenset({"counter"}))
    ex.end(1.0)
    assert ex.ended_by == ("counter", pytest.approx(0.3)) and ex.time == pytest.approx(0.3)
    ex.close()
    _equals_fmpy(fmu, tmp_path / "cb.mcap", 3, 1.0)


def test_the_command_line_says_which_fmu_ended_the_run_and_exits_0(counter, tmp_path, capsys):
    from tiltload.master.app.cli import main

    version, fmu = counter
    description = tmp_path / "system.json"
    description.write_text(json.dumps({"tick": TICK, "instances": [{"name": "counter", "fmu": str(fmu),
                                                                     "parameters": {"limit": 4}}]}))
    code = main(["run", "--system", str(description), "--stop-time", "1", "--out", str(tmp_path), "--no-plots", "--quiet"])
    said = capsys.readouterr()
    said = said.out + said.err
    assert code == 0, said
    assert "counter ended the run at t = 0.4 s" in said and "0.40 s simulated" in said


@pytest.mark.parametrize("by_callback", [False, True])
def test_a_system_that_takes_the_request_as_a_failure_fails_there(counter, tmp_path, by_callback):
    """System.fmu_end "error" (the thesis's loop: its plant stops when its state diverges): the run fails at the request,
    in the C loop and through its Python callback alike."""
    version, fmu = counter
    system = System(TICK, [Instance("counter", fmu, parameters={"limit": 2})], fmu_end="error")
    ex = Execution(system)
    ex.instantiate()
    if by_callback:
        ex.loop = NativeLoop(ex, by_callback=frozenset({"counter"}))
    with pytest.raises(Exception) as err:
        ex.end(1.0)
    ex.close()
    said = "doStep at t=0.2 s failed (discard)" if version == 2 else "the FMU asked to terminate the simulation at t=0.2 s"
    assert said in str(err.value) and ex.ended_by is None


def test_a_feedthrough_fmus_sample_at_zero_holds_its_connected_input(counter, tmp_path):
    """source.x -> sink.u, sink.y = u: the sink's sample at t = 0 is the source's x at 0 (1.5), not u's start value (0),
    and after that y at t_(k+1) is the x at t_(k+1) the source output in the same tick."""
    version, fmu = counter
    system = System(TICK, [Instance("source", fmu, parameters={"first": 3, "limit": 100}),
                           Instance("sink", fmu, parameters={"limit": 100})], auto_connect=False)
    system.connections = [Connection("source.x", "sink.u")]
    res = run_system(system, 0.3, tmp_path / "chain.mcap", progress=False)
    assert res.error is None
    columns, _ = log_reader.read_columns(tmp_path / "chain.mcap")
    x, y = columns["/source"][1]["x"], columns["/sink"][1]["y"]
    np.testing.assert_array_equal(columns["/sink"][0], columns["/source"][0])
    assert list(x) == [1.5, 2.0, 2.5, 3.0] and list(y) == list(x)


def test_an_fmu_in_a_worker_process_ends_the_run_the_same_way(counter, tmp_path):
    """The counter in a worker process of its own (isolation): its host replies to the step with the end (an E frame,
    its outputs there): the run ends at 0.3 s without an error, its last sample kept, FMPy's log."""
    version, fmu = counter
    system = System(TICK, [Instance("counter", fmu, parameters={"limit": 3})])
    res = run_system(system, 1.0, tmp_path / "iso.mcap", progress=False, isolate=lambda path, md: True)
    assert res.error is None and res.ended_by == ("counter", pytest.approx(0.3))
    _equals_fmpy(fmu, tmp_path / "iso.mcap", 3, 1.0)


def test_an_fmu_on_tiltload_serve_ends_the_run_the_same_way(counter, tmp_path):
    """The counter served by `tiltload serve` (its worker replies across the network as in a local worker)."""
    from support.remote import ServerProcess, token_file

    version, fmu = counter
    token = token_file(tmp_path)
    server = ServerProcess(fmu.parent, token, "--idle-timeout", "20")
    try:
        system = System(TICK, [Instance("counter", fmu, parameters={"limit": 4}, remote=server.address,
                                        token_file=token)])
        res = run_system(system, 1.0, tmp_path / "remote.mcap", progress=False)
        assert res.error is None and res.ended_by == ("counter", pytest.approx(0.4))
        _equals_fmpy(fmu, tmp_path / "remote.mcap", 4, 1.0)
        assert "exit 0" in server.wait_for("session ended")
    finally:
        server.stop()


def test_a_worker_s_end_is_a_failure_where_the_system_says_so(counter, tmp_path):
    version, fmu = counter
    system = System(TICK, [Instance("counter", fmu, parameters={"limit": 2})], fmu_end="error")
    ex = Execution(system, isolate=lambda path, md: True)
    ex.instantiate()
    with pytest.raises(Exception) as err:
        ex.end(1.0)
    ex.close()
    said = "doStep at t=0.2 s failed (discard)" if version == 2 else "the FMU asked to terminate the simulation at t=0.2 s"
    assert said in str(err.value) and ex.ended_by is None  # the worker's line, as in this process

"""A system that starts at t0 (issue 64: the SSD's DefaultExperiment startTime honoured): the FMUs set up at t0 (FMI 2.0
fmi2SetupExperiment, FMI 3.0 fmi3EnterInitializationMode), stepped at t0 + k * tick, logged from t0, the stop time an
absolute time, as FMPy's simulate_fmu(start_time=t0, stop_time=T) runs it.

The FMU is a clock built with the native FMU toolkit (support/counter_fmu/clock_model.c): now = the time its outputs
belong to, tenths = now in whole tenths (discrete), steps, y = u + now. The package (SSP 1.0, written here without any
tiltload annotation: the step is the FMUs' DefaultExperiment step) is source -> sink, source.now into sink.u, for
[1, 2]. Each instance is compared with FMPy running the FMU alone at every time tiltload logs (the discrete outputs: 0
difference; now: within 1e-12, FMPy's step being its next time minus its time, tiltload's the tick); the sink's y, which
tiltload samples after its input took the source's new value, with source.now + sink.now exactly."""

from __future__ import annotations

import json
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import simulate_fmu
from support.counter_fmu import clock_fmu
from tiltload.master.app.cli import main
from tiltload.master.engine.log import reader as log_reader
from tiltload.master.engine.run import run_system
from tiltload.master.engine.system import Connection, Instance, System

T0, STOP, STEP = 1.0, 2.0, 0.1


@pytest.fixture(scope="module", params=[2, 3], ids=["fmi2", "fmi3"])
def clock(request, tmp_path_factory):
    return request.param, clock_fmu(tmp_path_factory.mktemp(f"clock{request.param}"), request.param)


def _package(folder: Path, fmu: Path, start: float = T0, stop: float = STOP) -> Path:
    connectors = "".join(f'<ssd:Connector name="{n}" kind="{k}"><ssc:{t}/></ssd:Connector>' for n, k, t in (
        ("now", "output", "Real"), ("y", "output", "Real"), ("tenths", "output", "Integer"),
        ("steps", "output", "Integer"), ("u", "input", "Real")))
    components = "".join(f'<ssd:Component name="{name}" type="application/x-fmu-sharedlibrary" '
                         f'source="resources/{fmu.name}"><ssd:Connectors>{connectors}</ssd:Connectors></ssd:Component>'
                         for name in ("source", "sink"))
    ssd = f"""<?xml version="1.0" encoding="UTF-8"?>
<ssd:SystemStructureDescription xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription"
    xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon" version="1.0" name="clocks">
  <ssd:System name="clocks">
    <ssd:Elements>{components}</ssd:Elements>
    <ssd:Connections><ssd:Connection startElement="source" startConnector="now" endElement="sink" endConnector="u"/>
    </ssd:Connections>
  </ssd:System>
  <ssd:DefaultExperiment startTime="{start!r}" stopTime="{stop!r}"/>
</ssd:SystemStructureDescription>
"""
    from tiltload.master.engine.ssp.schema import schema_errors

    assert schema_errors(ssd.encode(), "ssd") == []
    package = folder / "clocks.ssp"
    with zipfile.ZipFile(package, "w") as z:
        z.writestr("SystemStructure.ssd", ssd)
        z.write(fmu, f"resources/{fmu.name}")
    return package


def _columns(log: Path) -> dict[str, tuple[np.ndarray, dict]]:
    columns, state = log_reader.read_columns(log)
    assert state.damage is None
    return {name: (np.asarray(t, dtype=float), {k: np.asarray(v) for k, v in fields.items()})
            for name, (t, fields) in ((n[1:], c) for n, c in columns.items() if n in ("/source", "/sink"))}


def _equal_fmpy(t: np.ndarray, fields: dict, ref, reals=("now", "y")) -> None:
    """Ours at every time we log against FMPy's row at that time (its last there), every time FMPy has."""
    assert len(np.unique(np.round(ref["time"], 9))) == len(t) and len(np.unique(t)) == len(t)
    rows = [np.flatnonzero(np.isclose(ref["time"], s, rtol=0, atol=1e-9))[-1] for s in t]
    np.testing.assert_allclose(t, ref["time"][rows], rtol=0, atol=1e-12)
    for name in ("tenths", "steps"):
        np.testing.assert_array_equal(fields[name], ref[name][rows], err_msg=name)
    for name in reals:
        np.testing.assert_allclose(fields[name], ref[name][rows], rtol=0, atol=1e-12, err_msg=name)


def test_a_package_for_1_to_2_runs_from_1_as_fmpy_runs_it(clock, tmp_path):
    version, fmu = clock
    package = _package(tmp_path, fmu)
    out = tmp_path / "run"
    assert main(["run", "--system", str(package), "--out", str(out), "--no-plots", "--quiet"]) == 0  # isolated: its own
    logged = _columns(next(out.rglob("*.mcap")))
    t, source = logged["source"]
    assert t[0] == T0 and t[-1] == STOP and len(t) == 11  # from the start time to the stop time, an absolute time
    assert source["now"][0] == T0 and source["tenths"][0] == 10 and source["steps"][-1] == 10
    _equal_fmpy(t, source, simulate_fmu(str(fmu), start_time=T0, stop_time=STOP, output_interval=STEP))
    t_sink, sink = logged["sink"]
    assert np.array_equal(t_sink, t)
    _equal_fmpy(t, sink, simulate_fmu(str(fmu), start_time=T0, stop_time=STOP, output_interval=STEP), reals=("now",))
    # its feedthrough: the source's now at every sample, the one at t0 too (connected at initialization: 1 + 1)
    assert sink["y"][0] == 2 * T0 and np.array_equal(sink["y"], source["now"] + sink["now"])


def test_a_start_time_runs_the_same_in_this_process_and_in_a_worker(clock, tmp_path):
    """The engine alone (a System with start_time): the FMU in this process and in a worker process log the same."""
    version, fmu = clock
    logs = []
    for isolate in (None, lambda *_: True):
        system = System(STEP, [Instance("source", fmu), Instance("sink", fmu)], [Connection("source.now", "sink.u")],
                        start_time=T0)
        log = tmp_path / f"{'isolated' if isolate else 'here'}.mcap"
        res = run_system(system, STOP, log, progress=False, isolate=isolate)
        assert res.error is None and res.sim_time == pytest.approx(STOP) and res.ticks == 10
        logs.append(_columns(log))
    for name in ("source", "sink"):
        assert np.array_equal(logs[0][name][0], logs[1][name][0])
        for k, v in logs[0][name][1].items():
            assert np.array_equal(v, logs[1][name][1][k]), (name, k)
    assert logs[0]["source"][0][0] == T0 and logs[0]["source"][1]["tenths"][-1] == 20


def _system_file(folder: Path, fmu: Path, **extra) -> Path:
    path = folder / "clocks.json"
    path.write_text(json.dumps({"tick": STEP, "start_time": T0, "instances": [
        {"name": "source", "fmu": str(fmu)}, {"name": "sink", "fmu": str(fmu)}],
        "connections": [{"source": "source.now", "target": "sink.u"}], **extra}))
    return path


def test_a_system_file_s_start_time_and_start_time_option_run_as_the_package_s(clock, tmp_path):
    """A JSON description's "start_time", and --start-time over a description that has none (the API's
    Case.start_time the same): the same run as the SSD's DefaultExperiment startTime (logs equal)."""
    import tiltload as tl

    version, fmu = clock
    plain = _system_file(tmp_path, fmu)
    data = json.loads(plain.read_text())
    del data["start_time"]
    (tmp_path / "from0.json").write_text(json.dumps(data))
    logs = {}
    for name, path, extra in (("json", plain, []), ("ssp", _package(tmp_path, fmu), []),
                              ("option", tmp_path / "from0.json", ["--start-time", "1"])):
        assert main(["run", "--system", str(path), "--stop-time", repr(STOP), "--out", str(tmp_path / name),
                     "--no-plots", "--quiet", "--trust-fmus", *extra]) == 0
        logs[name] = log_reader.read(next((tmp_path / name).rglob("*.mcap")))
    outcome = tl.run(tl.Case(system=tmp_path / "from0.json", start_time=T0, stop_time=STOP),
                     tl.RunOptions(out=tmp_path / "api", no_plots=True, quiet=True, trust_fmus=True))
    logs["api"] = log_reader.read(outcome.log)
    for name in ("ssp", "option", "api"):
        assert logs[name]["/source"] == logs["json"]["/source"] and logs[name]["/sink"] == logs["json"]["/sink"], name
    assert logs["json"]["/source"][0]["t"] == T0 and logs["json"]["/source"][-1]["t"] == pytest.approx(STOP)


def test_start_time_is_for_a_system_file_only(capsys):
    assert main(["run", "--start-time", "1", "--stop-time", "2", "--no-plots", "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--start-time is for --system: the loop runs from t = 0" in err, err


@pytest.mark.parametrize("what, extra, said", [
    ("faults", {"faults": [{"target": "sink.u", "action": "bias", "value": 1.0, "start": 1.2, "end": 1.5}]},
     "the system starts at 1 s and has faults, which tiltload schedules from t = 0 only"),
    ("requirements", "--requirements", "the system starts at 1 s: --requirements, --snapshot-at and --from-snapshot "
                                       "are for runs from t = 0 only"),
    ("snapshot", "--snapshot-at", "the system starts at 1 s: --requirements, --snapshot-at and --from-snapshot are for "
                                  "runs from t = 0 only"),
], ids=["faults", "requirements", "snapshot"])
def test_what_runs_from_0_only_is_refused_in_one_line_for_a_later_start(what, extra, said, clock, tmp_path, capsys):
    version, fmu = clock
    argv = []
    if extra == "--requirements":
        requirements = tmp_path / "req.json"
        requirements.write_text("{}")
        argv = [extra, str(requirements)]
    elif extra == "--snapshot-at":
        argv = [extra, "1.5", str(tmp_path / "s.snap")]
    path = _system_file(tmp_path, fmu, **(extra if isinstance(extra, dict) else {}))
    code = main(["run", "--system", str(path), "--stop-time", repr(STOP), "--out", str(tmp_path / "out"), "--no-plots",
                 "--quiet", *argv])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and said in err, err
    assert not list((tmp_path / "out").rglob("*.mcap"))  # refused before the run


def test_an_fmu_on_tiltload_serve_starts_at_t0_connected_as_in_this_process(clock, tmp_path):
    """The init request carries the start time and the connected inputs across the network too (remote protocol 3):
    the served sink's log, its sample at t0 included (y = 1 + 1, the source's now set in its Initialization Mode),
    equals the in-process run's."""
    from support.remote import ServerProcess, token_file

    version, fmu = clock
    token = token_file(tmp_path)
    server = ServerProcess(fmu.parent, token, "--idle-timeout", "20")
    try:
        logs = []
        for remote in (None, server.address):
            sink = Instance("sink", fmu, remote=remote)
            sink.token_file = token if remote else None
            system = System(STEP, [Instance("source", fmu), sink], [Connection("source.now", "sink.u")], start_time=T0)
            log = tmp_path / f"{'served' if remote else 'here'}.mcap"
            res = run_system(system, STOP, log, progress=False)
            assert res.error is None, res.error
            logs.append(log_reader.read(log))
    finally:
        server.stop()
    served, here = logs[1]["/sink"], logs[0]["/sink"]
    assert served[0]["t"] == T0 and served[0]["y"] == 2 * T0 and served == here and len(served) == 11


def test_a_stop_time_off_the_grid_after_a_later_start_ends_with_a_shorter_last_step(clock, tmp_path):
    """[1, 1.25] on a 0.1 s tick: steps at 1, 1.1, 1.2 (0.05 s, the FMU takes a variable step), FMPy's times and values."""
    version, fmu = clock
    system = System(STEP, [Instance("source", fmu)], start_time=T0)
    res = run_system(system, 1.25, tmp_path / "run.mcap", progress=False)
    assert res.error is None and res.sim_time == 1.25
    t, fields = _columns(tmp_path / "run.mcap")["source"]
    assert len(t) == 4 and t[-1] == 1.25 and fields["steps"][-1] == 3
    _equal_fmpy(t, fields, simulate_fmu(str(fmu), start_time=T0, stop_time=1.25, output_interval=STEP), reals=("now",))


def test_an_fmu_with_clocks_refuses_a_later_start_in_one_line(tmp_path):
    """The master counts an FMI 3.0 FMU's clock ticks from t = 0: a system that starts later is refused when read."""
    from support.fmi3_trace_fmu import TICK, trace_fmu
    from tiltload.master.engine.errors import DescriptionError
    from tiltload.master.engine.execution import Execution

    system = System(TICK, [Instance("dut", trace_fmu(tmp_path))], start_time=T0)
    with pytest.raises(DescriptionError) as err:
        Execution(system)
    assert str(err.value) == "the system starts at 1 s and dut has clocks, which tiltload ticks from t = 0 only"


def test_a_restart_with_faults_is_refused_for_a_later_start_as_a_fresh_run_is(clock, tmp_path):
    """A pooled execution restarted with faults (a campaign's or the API's pool) meets the same rule as a fresh run: a
    system that starts after 0 takes no faults, said in one line, the execution left as it was."""
    from tiltload.master.engine.errors import DescriptionError
    from tiltload.master.engine.execution import Execution
    from tiltload.master.engine.faults.parse import parse as parse_faults

    _, fmu = clock
    system = System(STEP, [Instance("source", fmu), Instance("sink", fmu)], [Connection("source.now", "sink.u")],
                    start_time=T0)
    ex = Execution(system, [])
    ex.instantiate()
    try:
        faults = parse_faults([{"target": "sink.u", "action": "bias", "value": 1.0, "start": 1.2, "end": 1.5}])
        with pytest.raises(DescriptionError, match="the system starts at 1 s and has faults, which tiltload schedules "
                                                   "from t = 0 only"):
            ex.restart(faults=faults)
        assert ex.system.faults == [] and ex.manipulator is None
        ex.restart()
        ex.run(STOP)
        assert ex.time == pytest.approx(STOP)
    finally:
        ex.close()


def test_an_fmu_on_tl_serve_starts_at_t0_connected_as_in_this_process(tmp_path):
    """The C server (tl_serve.c, the processor-in-the-loop's, FMI 2.0) speaks protocol 3 too: the init request's start
    time and connected inputs set in the FMU's Initialization Mode, so the served sink's log, its sample at t0 (y = 1 +
    1) included, equals the in-process run's."""
    from tiltload.master.app.regression import pil
    from tiltload.native_fmu.compile import host_platform

    fmu = clock_fmu(tmp_path / "fmi2", 2)
    logs = []
    with pil.served(fmu, host_platform()) as host:
        for remote in (None, host.address):
            sink = Instance("sink", fmu, remote=remote)
            sink.token_file = host.token_file if remote else None
            system = System(STEP, [Instance("source", fmu), sink], [Connection("source.now", "sink.u")], start_time=T0)
            log = tmp_path / f"{'served' if remote else 'here'}.mcap"
            res = run_system(system, STOP, log, progress=False)
            assert res.error is None, res.error
            logs.append(log_reader.read(log))
    served, here = logs[1]["/sink"], logs[0]["/sink"]
    assert served[0]["t"] == T0 and served[0]["y"] == 2 * T0 and served == here and len(served) == 11


def test_tl_serve_refuses_an_fmu_with_a_string_output_in_one_line(tmp_path):
    """tl_serve gets and sends numbers and Booleans only: an FMU with a String output (which would be neither logged
    nor connected) is refused when the server starts, in one line naming the FMU. The FMU: the clock with a String
    output added to its model description (tl_serve reads the description before it calls the binary)."""
    from tiltload.master.app.regression import pil
    from tiltload.master.engine.errors import DescriptionError
    from tiltload.native_fmu.compile import host_platform

    clock = clock_fmu(tmp_path / "fmi2", 2)
    fmu = tmp_path / "labelled.fmu"
    with zipfile.ZipFile(clock) as src, zipfile.ZipFile(fmu, "w") as out:
        for item in src.infolist():
            data = src.read(item.filename)
            if item.filename == "modelDescription.xml":
                data = data.replace(b"</ModelVariables>", b'<ScalarVariable name="label" valueReference="4242" '
                                    b'causality="output" variability="discrete"><String/></ScalarVariable>'
                                    b"</ModelVariables>")
            out.writestr(item, data)
    for served_fmu, refused in ((clock, False), (fmu, True)):
        try:
            with pil.served(served_fmu, host_platform()):
                said = None
        except DescriptionError as err:
            said = str(err)
        assert (said is not None) == refused, said
    assert "has a String output; tl_serve serves FMUs whose outputs are numbers and Booleans" in said
    assert len(said.splitlines()) == 1

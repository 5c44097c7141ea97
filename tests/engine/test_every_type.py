"""Every FMI value type (issue 64): set, connected and logged with its type, FMI 2.0 and 3.0. The FMUs
(support/every_type_fmu) have a parameter, an input and an output of each type; FMPy's simulate_fmu of the same FMU with
the same start values is the reference at every time tiltload logs (0 difference: the model is discrete arithmetic).
A connection carries a type into the same or a wider one; anything lossy is refused naming both ends; array variables
are refused when the system is read."""

from __future__ import annotations

import json

import numpy as np
import pytest
from fmpy import simulate_fmu
from support.every_type_fmu import FMI2_TYPES, FMI3_TYPES, every_type_fmu
from tiltload.master.engine.errors import DescriptionError
from tiltload.master.engine.execution import Execution
from tiltload.master.engine.log import reader as log_reader
from tiltload.master.engine.run import run_system
from tiltload.master.engine.system import Connection, Instance, System

TICK = 0.1
# values beyond the narrower types' ranges where the type allows: a wrong carrier or conversion shows
START = {"Float32": 0.1, "Float64": 0.3, "Int8": -7, "UInt8": 11, "Int16": -300, "UInt16": 600, "Int32": -70000,
         "UInt32": 3_000_000_000, "Int64": -(2**40) - 3, "UInt64": 2**45 + 5, "Boolean": True, "Enumeration": 2,
         "Real": 0.3, "Integer": -70000}
INPUT = {"Float32": 0.5, "Float64": 1.25, "Int8": 100, "UInt8": 200, "Int16": 30000, "UInt16": 60000, "Int32": 2**30,
         "UInt32": 4_000_000_000, "Int64": 2**50, "UInt64": 2**51, "Boolean": True, "Enumeration": 3, "Real": 1.25,
         "Integer": 2**30}
INTEGERS = {"Int8", "UInt8", "Int16", "UInt16", "Int32", "UInt32", "Int64", "UInt64", "Enumeration", "Integer"}


@pytest.fixture(scope="module", params=[2, 3], ids=["fmi2", "fmi3"])
def fmu(request, tmp_path_factory):
    return request.param, every_type_fmu(tmp_path_factory.mktemp(f"types{request.param}"), request.param)


def _types(version: int) -> tuple[str, ...]:
    return FMI3_TYPES if version == 3 else FMI2_TYPES


def _start_values(version: int) -> dict:
    # Float64 -2^40 and beyond need 53 bits: the k steps' product stays exact
    return {**{f"p_{t}": START[t] for t in _types(version)}, **{f"u_{t}": INPUT[t] for t in _types(version)}}


def _logged(log, topic: str) -> list[dict]:
    return log_reader.read(log)[f"/{topic}"]


def _equals_fmpy(fmu, messages: list[dict], version: int, stop: float, start_values: dict, outputs=None,
                 start: float = 0.0) -> None:
    """Every logged message equals FMPy's row at its time, value and kind (int, bool, float) alike."""
    ref = simulate_fmu(str(fmu), start_time=start, stop_time=stop, output_interval=TICK, start_values=start_values)
    times = [m["t"] for m in messages]
    assert len(times) == len(set(times)) == len(np.unique(np.round(ref["time"], 9)))
    for m in messages:
        row = np.flatnonzero(np.isclose(ref["time"], m["t"], rtol=0, atol=1e-9))[-1]
        for t in outputs or _types(version):
            expected, got = ref[f"y_{t}"][row].item(), m[f"y_{t}"]
            assert got == expected, (m["t"], t, got, expected)
            kind = bool if t == "Boolean" else int if t in INTEGERS else float
            assert type(got) is kind, (t, type(got))


def test_every_type_is_set_and_logged_as_fmpy_simulates_it(fmu, tmp_path):
    version, path = fmu
    values = _start_values(version)
    res = run_system(System(TICK, [Instance("e", path, parameters=values)]), 0.5, tmp_path / "run.mcap", progress=False)
    assert res.error is None
    messages = _logged(tmp_path / "run.mcap", "e")
    assert len(messages) == 6 and messages[-1]["t"] == pytest.approx(0.5)
    _equals_fmpy(path, messages, version, 0.5, values)


def test_the_log_schema_gives_each_output_its_type(fmu, tmp_path):
    from mcap.reader import make_reader

    version, path = fmu
    run_system(System(TICK, [Instance("e", path)]), 0.1, tmp_path / "run.mcap", progress=False)
    with open(tmp_path / "run.mcap", "rb") as f:
        summary = make_reader(f).get_summary()
    channel = next(c for c in summary.channels.values() if c.topic == "/e")
    schema = json.loads(summary.schemas[channel.schema_id].data)["properties"]
    assert schema["y_Enumeration"]["oneOf"] == [{"const": 1, "title": "red"}, {"const": 2, "title": "green"},
                                                {"const": 3, "title": "blue"}]
    assert schema["y_Boolean"] == {"type": "boolean"}
    if version == 3:
        assert schema["y_Int8"] == {"type": "integer", "description": "Int8", "minimum": -128, "maximum": 127}
        assert schema["y_UInt64"]["maximum"] == 2**64 - 1 and schema["y_Float32"]["description"] == "Float32"


def test_the_isolated_worker_converts_the_same_way(tmp_path):
    """The FMI 3.0 FMU in a worker process of its own: the same log as FMPy's result."""
    path = every_type_fmu(tmp_path, 3)
    values = _start_values(3)
    ex = Execution(System(TICK, [Instance("e", path, parameters=values)]), isolate=lambda fmu, md: True)
    from tiltload.master.engine.log.logger import McapLogger

    ex.observers = [McapLogger(tmp_path / "iso.mcap")]
    ex.instantiate()
    try:
        assert ex.loop.paths["e"] == "callback: worker process"
        ex.end(0.3)
    finally:
        ex.close()
    _equals_fmpy(path, _logged(tmp_path / "iso.mcap", "e"), 3, 0.3, values)


def test_a_connection_of_every_type_carries_it_exactly(fmu, tmp_path):
    """source.y_T -> sink.u_T for every type, the sink's own parameters neutral (p = 0, Boolean false, Enumeration
    items such that y = u): the sink's output equals the source's at every logged time, t = 0 included (set in
    Initialization Mode), and the source's equals FMPy's."""
    version, path = fmu
    types = _types(version)
    values = _start_values(version)
    neutral = {f"p_{t}": (False if t == "Boolean" else 0) for t in types if t != "Enumeration"}
    neutral["p_Enumeration"] = 2  # y = 1 + (u + 2 + k) % 3: u's item at k = 0, the same shift a step as the source's
    system = System(TICK, [Instance("source", path, parameters=values), Instance("sink", path, parameters=neutral)],
                    auto_connect=False)
    system.connections = [Connection(f"source.y_{t}", f"sink.u_{t}") for t in types]
    res = run_system(system, 0.3, tmp_path / "chain.mcap", progress=False)
    assert res.error is None
    source, sink = _logged(tmp_path / "chain.mcap", "source"), _logged(tmp_path / "chain.mcap", "sink")
    _equals_fmpy(path, source, version, 0.3, values)
    assert [m["t"] for m in sink] == [m["t"] for m in source]
    for a, b in zip(source, sink):
        for t in types:
            if t == "Enumeration":  # the sink adds k + 2 (mod 3) to its input: one item on per step beyond the source's
                continue
            assert b[f"y_{t}"] == a[f"y_{t}"], (a["t"], t)


@pytest.mark.parametrize("source, target", [("Int8", "Int16"), ("UInt16", "Int32"), ("Float32", "Float64"),
                                            ("UInt32", "Int64"), ("UInt32", "UInt64"), ("UInt32", "Float64")])
def test_a_lossless_conversion_is_carried(tmp_path, source, target):
    """A wider target takes the source's values exactly (compared with FMPy's source run)."""
    path = every_type_fmu(tmp_path, 3)
    values = _start_values(3)
    system = System(TICK, [Instance("a", path, parameters=values), Instance("b", path, parameters={
        f"p_{target}": 0})], auto_connect=False)
    system.connections = [Connection(f"a.y_{source}", f"b.u_{target}")]
    assert run_system(system, 0.3, tmp_path / "run.mcap", progress=False).error is None
    a, b = _logged(tmp_path / "run.mcap", "a"), _logged(tmp_path / "run.mcap", "b")
    _equals_fmpy(path, a, 3, 0.3, values, outputs=[source])
    assert [m[f"y_{target}"] for m in b] == [m[f"y_{source}"] for m in a]


@pytest.mark.parametrize("source, target, said", [
    ("Float64", "Float32", "a.y_Float64 -> b.u_Float32: Float64 -> Float32 would lose values"),
    ("Int16", "Int8", "a.y_Int16 -> b.u_Int8: Int16 -> Int8 would lose values"),
    ("Int8", "UInt8", "Int8 -> UInt8 would lose values"),
    ("Int64", "Float64", "Int64 -> Float64 would lose values"),
    ("Float32", "Int32", "Float32 -> Int32 would lose values"),
    ("Boolean", "Int8", "Boolean -> Int8 would lose values"),
    ("Enumeration", "Int64", "an Enumeration connects only to an Enumeration of the same items"),
    ("Int8", "UInt32", "Int8 -> UInt32 would lose values"),
    ("Int32", "Float32", "Int32 -> Float32 would lose values"),
    ("String", "Binary", "a.y_String -> b.u_Binary: String -> Binary: a String connects only to a String"),
    ("Int32", "String", "Int32 -> String: a String connects only to a String")])
def test_a_lossy_or_unsupported_connection_is_refused_naming_both_ends(tmp_path, source, target, said):
    path = every_type_fmu(tmp_path, 3)
    system = System(TICK, [Instance("a", path), Instance("b", path)], auto_connect=False)
    system.connections = [Connection(f"a.y_{source}", f"b.u_{target}")]
    with pytest.raises(DescriptionError, match=said.replace("(", r"\(").replace(")", r"\)")) as err:
        Execution(system)
    assert "\n" not in str(err.value)


@pytest.mark.parametrize("name, value, said", [
    ("p_Int8", 128, "must be a whole number in Int8's range [-128, 127]"),
    ("p_UInt64", -1, "must be a whole number in UInt64's range [0, 18446744073709551615]"),
    ("p_Enumeration", 4, "not one of its items (red=1, green=2, blue=3)"),
    ("p_Float32", 1e39, "beyond Float32's range"),
    ("p_Int16", 1.5, "must be a whole number")])
def test_a_value_outside_its_type_is_refused(tmp_path, name, value, said):
    path = every_type_fmu(tmp_path, 3)
    with pytest.raises(DescriptionError, match=said.replace("(", r"\(").replace(")", r"\)").replace("[", r"\[")
                       .replace("]", r"\]")):
        Execution(System(TICK, [Instance("e", path, parameters={name: value})]))


def test_an_array_variable_is_refused_when_the_system_is_read(tmp_path):
    """FMI 3.0 arrays are not supported: refused before anything is loaded, naming the variable (not at t = 0 with
    the FMU's own message)."""
    path = every_type_fmu(tmp_path, 3, '<Float64 name="a" valueReference="500" causality="output" '
                                       'variability="continuous"><Dimension start="3"/></Float64>')
    with pytest.raises(DescriptionError, match="has the array variable a .Float64 with dimensions.: array variables are "
                                               "not supported"):
        Execution(System(TICK, [Instance("e", path)]))


def test_the_command_line_sets_every_type_from_a_system_file_and_set(fmu, tmp_path, capsys):
    from tiltload.master.app.cli import main

    version, path = fmu
    values = _start_values(version)
    description = tmp_path / "system.json"
    description.write_text(json.dumps({"tick": TICK, "instances": [{"name": "e", "fmu": str(path),
                                                                     "parameters": values}]}))
    code = main(["run", "--system", str(description), "--stop-time", "0.3", "--out", str(tmp_path / "out"),
                 "--no-plots", "--quiet", "--set", "e.p_Enumeration=3"])
    assert code == 0, capsys.readouterr()
    log = next((tmp_path / "out").rglob("*.mcap"))
    _equals_fmpy(path, _logged(log, "e"), version, 0.3, {**values, "p_Enumeration": 3})
    code = main(["run", "--system", str(description), "--stop-time", "0.3", "--out", str(tmp_path / "bad"),
                 "--no-plots", "--quiet", "--set", "e.p_Enumeration=7"])
    said = capsys.readouterr().err.strip()
    assert code == 2 and "e.p_Enumeration = 7: not one of its items" in said and len(said.splitlines()) == 1


def test_an_ssp_export_of_every_type_runs_back_as_the_system_file_does(fmu, tmp_path, capsys):
    """`ssp export` of a system holding every type (parameters of each, every output connected; an Enumeration given
    by its item's name), FMI 2.0 (SSP 1.0) and 3.0 (SSP 2.0): the package validates (the export checks it against
    the SSP schemas), and `run --system` of it logs what the system file's run logs, message for message."""
    from tiltload.master.app.cli import main

    version, path = fmu
    types = _types(version)
    values = {**_start_values(version), "p_Enumeration": "green"}
    description = tmp_path / "every.json"
    description.write_text(json.dumps({
        "tick": TICK, "auto_connect": False,
        "instances": [{"name": "source", "fmu": str(path), "parameters": values},
                      {"name": "sink", "fmu": str(path), "parameters": {"p_Int32" if version == 3 else "p_Integer": 1}}],
        "connections": [{"source": f"source.y_{t}", "target": f"sink.u_{t}"} for t in types]}))
    package = tmp_path / "every.ssp"
    assert main(["ssp", "export", str(package), "--system", str(description), "--stop-time", "0.3",
                 "--schedule", "ordered"]) == 0, capsys.readouterr()
    said = capsys.readouterr().out
    assert f"SSP {'2.0' if version == 3 else '1.0'} package" in said
    logs = {}
    for name, system in (("json", description), ("ssp", package)):
        code = main(["run", "--system", str(system), "--stop-time", "0.3", "--out", str(tmp_path / name), "--no-plots",
                     "--quiet"])
        assert code == 0, capsys.readouterr()
        logs[name] = next((tmp_path / name).rglob("*.mcap"))
    for topic in ("source", "sink"):
        assert _logged(logs["ssp"], topic) == _logged(logs["json"], topic)
    _equals_fmpy(path, _logged(logs["ssp"], "source"), version, 0.3, {**values, "p_Enumeration": 2})


def _standard_package(tmp_path, fmu, start: float = 0.0, stop: float = 0.3):
    """An SSP 1.0 package as another tool writes one: no tiltload or libcosim annotation, so no master step."""
    import zipfile

    ssd = f"""<?xml version="1.0" encoding="UTF-8"?>
<ssd:SystemStructureDescription xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription"
    xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon" version="1.0" name="standard">
  <ssd:System name="standard">
    <ssd:Elements>
      <ssd:Component name="e" type="application/x-fmu-sharedlibrary" source="resources/{fmu.name}"/>
    </ssd:Elements>
  </ssd:System>
  <ssd:DefaultExperiment startTime="{start}" stopTime="{stop}"/>
</ssd:SystemStructureDescription>
"""
    package = tmp_path / f"standard{start:g}.ssp"
    with zipfile.ZipFile(package, "w") as z:
        z.writestr("SystemStructure.ssd", ssd)
        z.write(fmu, f"resources/{fmu.name}")
    return package


def test_a_standard_ssp_package_runs_on_its_fmus_declared_step_to_its_stop_time(fmu, tmp_path, capsys):
    """No step annotation: the FMUs' DefaultExperiment stepSize (0.1 s) is the step, said in one line; the SSD's stop
    time ends the run (no --stop-time); the log equals FMPy's run of the FMU to that time."""
    from tiltload.master.app.cli import main

    version, path = fmu
    package = _standard_package(tmp_path, path)
    code = main(["run", "--system", str(package), "--out", str(tmp_path / "out"), "--no-plots"])
    said = capsys.readouterr()
    assert code == 0, said
    lines = [line for line in said.out.splitlines() if "no step annotation" in line]
    assert len(lines) == 1 and "step 0.1 s (the smallest of its FMUs' DefaultExperiment step sizes" in lines[0]
    assert "declared: e 0.1 s" in lines[0]
    messages = _logged(next((tmp_path / "out").rglob("*.mcap")), "e")
    assert messages[-1]["t"] == pytest.approx(0.3)
    _equals_fmpy(path, messages, version, 0.3, {})


def test_a_standard_package_for_1_to_2_runs_from_1_as_fmpy_runs_it(fmu, tmp_path, capsys):
    """The SSD's DefaultExperiment [1, 2]: the FMU set up at 1 s, stepped at 1 + k * 0.1 s and logged from 1 s to 2 s
    (the stop time an absolute time), equal to FMPy's simulate_fmu(start_time=1, stop_time=2) at every time (0
    difference); the run says it simulated 1 s from t = 1 s."""
    from tiltload.master.app.cli import main

    version, path = fmu
    code = main(["run", "--system", str(_standard_package(tmp_path, path, start=1.0, stop=2.0)), "--out",
                 str(tmp_path / "out"), "--no-plots", "--quiet"])
    said = capsys.readouterr().out
    assert code == 0, said
    assert ": 1 s of simulated time from t = 1 s" in said and "1.00 s simulated in" in said
    messages = _logged(next((tmp_path / "out").rglob("*.mcap")), "e")
    assert messages[0]["t"] == 1.0 and messages[-1]["t"] == pytest.approx(2.0) and len(messages) == 11
    _equals_fmpy(path, messages, version, 2.0, {}, start=1.0)


def test_a_stop_time_before_the_start_time_is_refused_in_one_line(fmu, tmp_path, capsys):
    from tiltload.master.app.cli import main

    version, path = fmu
    code = main(["run", "--system", str(_standard_package(tmp_path, path, start=1.0, stop=2.0)), "--stop-time", "0.5",
                 "--out", str(tmp_path / "out"), "--no-plots", "--quiet"])
    said = capsys.readouterr().err.strip()
    assert code == 2 and len(said.splitlines()) == 1
    assert "stop time 0.5 s: the system starts at 1 s, and its stop time is an absolute time after that" in said


def test_a_stop_time_off_the_tick_grid_is_met_with_a_shorter_last_step(tmp_path):
    """0.25 s on a 0.1 s tick: the FMU takes a variable step (canHandleVariableCommunicationStepSize), so the last step
    is 0.05 s and the last sample is at 0.25 s, FMPy's last time and values too (through the converting callback)."""
    path = every_type_fmu(tmp_path, 3)
    values = _start_values(3)
    res = run_system(System(TICK, [Instance("e", path, parameters=values)]), 0.25, tmp_path / "run.mcap", progress=False)
    assert res.error is None and res.sim_time == 0.25
    messages = _logged(tmp_path / "run.mcap", "e")
    assert [m["t"] for m in messages][-2:] == [pytest.approx(0.2), 0.25]
    _equals_fmpy(path, messages, 3, 0.25, values)


def test_an_algebraic_loop_is_refused_in_one_line_and_a_delay_breaks_it(fmu, tmp_path):
    """a.y -> b.u and b.y -> a.u, each output depending directly on its input (declared in the model descriptions): no
    order sets the inputs at t = 0 from final values, so the system is refused naming the cycle; with a delay on one
    connection it runs."""
    version, path = fmu
    real = "Float64" if version == 3 else "Real"
    system = System(TICK, [Instance("a", path), Instance("b", path)], auto_connect=False)
    system.connections = [Connection(f"a.y_{real}", f"b.u_{real}"), Connection(f"b.y_{real}", f"a.u_{real}")]
    with pytest.raises(DescriptionError) as err:
        Execution(system)
    said = str(err.value)
    assert "\n" not in said and said.startswith("algebraic loop: ") and "give one of its connections a delay" in said
    assert {f"a.y_{real}", f"b.u_{real}", f"b.y_{real}", f"a.u_{real}"} <= set(said.split(": ", 1)[1].split(" (")[0]
                                                                          .split(" -> "))
    system.connections[1] = Connection(f"b.y_{real}", f"a.u_{real}", 1)
    assert run_system(system, 0.2, tmp_path / "run.mcap", progress=False).error is None


def test_a_chain_of_three_is_initialized_sources_first(fmu, tmp_path):
    """c <- b <- a, listed the other way round: each sample at t = 0 holds its connected value (y = u + p * 0), so the
    three are equal at 0 whatever the system's order (after it, the steps follow the system's order: c, then b, a
    tick behind their sources)."""
    version, path = fmu
    real = "Float64" if version == 3 else "Real"
    system = System(TICK, [Instance("c", path, parameters={f"p_{real}": 0}), Instance("b", path, parameters={f"p_{real}": 0}),
                           Instance("a", path, parameters={f"p_{real}": 0.5, f"u_{real}": 2.0})], auto_connect=False)
    system.connections = [Connection(f"b.y_{real}", f"c.u_{real}"), Connection(f"a.y_{real}", f"b.u_{real}")]
    assert run_system(system, 0.3, tmp_path / "run.mcap", progress=False).error is None
    a, b, c = (_logged(tmp_path / "run.mcap", name) for name in "abc")
    assert a[0][f"y_{real}"] == b[0][f"y_{real}"] == c[0][f"y_{real}"] == 2.0
    _equals_fmpy(path, a, version, 0.3, {f"p_{real}": 0.5, f"u_{real}": 2.0}, outputs=[real])
    ys = {name: [m[f"y_{real}"] for m in log] for name, log in (("a", a), ("b", b), ("c", c))}
    assert ys["b"][1:] == ys["a"][:-1] and ys["c"][1:] == ys["b"][:-1]


def _table(version: int) -> tuple[list[str], list[list]]:
    """Inputs over time: continuous ones change between the ticks, discrete ones on a tick (0.2 s, FMPy's input event
    there is a communication point of ours too), a jump at 0.2 s (two rows)."""
    floats = ["u_Float64", "u_Float32"] if version == 3 else ["u_Real"]
    whole = ["u_Int8", "u_UInt64"] if version == 3 else ["u_Integer"]
    names = ["time", *floats, *whole, "u_Boolean", "u_Enumeration"]
    rows = [(0.0, 0.5, 1, 0, 1), (0.15, 2.0, 1, 0, 1), (0.2, 2.0, 3, 1, 2), (0.2, -1.0, 4, 0, 3), (0.45, 4.0, 4, 0, 3)]
    table = [[t, *[x] * len(floats), *[n * (2**40 if w == "u_UInt64" else 1) for w in whole], b, e]
             for t, x, n, b, e in rows]
    return names, table


@pytest.mark.parametrize("kind", ["csv", "parquet"])
def test_an_input_file_drives_an_fmu_as_fmpy_s_input_file_does(fmu, tmp_path, kind):
    """An input file (CSV, Parquet) for the FMU's inputs: continuous ones interpolated, discrete ones held, a jump at
    0.2 s; the log equals FMPy's simulate_fmu with the same table (read by FMPy's read_csv) at every logged time."""
    from fmpy.util import read_csv

    version, path = fmu
    names, rows = _table(version)
    csv = tmp_path / "inputs.csv"
    csv.write_text(",".join(names) + "\n" + "\n".join(",".join(repr(x) for x in row) for row in rows) + "\n")
    table = csv
    if kind == "parquet":
        import pyarrow as pa
        import pyarrow.parquet as pq

        table = tmp_path / "inputs.parquet"
        pq.write_table(pa.table({n: [row[j] for row in rows] for j, n in enumerate(names)}), table)
    values = {f"p_{t}": START[t] for t in _types(version) if t != "Boolean"}
    system = System(TICK, [Instance("e", path, parameters=values, input_file=table)])
    assert run_system(system, 0.5, tmp_path / "run.mcap", progress=False).error is None
    ref = simulate_fmu(str(path), stop_time=0.5, output_interval=TICK, start_values=values, input=read_csv(csv))
    messages = _logged(tmp_path / "run.mcap", "e")
    assert len(messages) == 6
    for m in messages:
        row = np.flatnonzero(np.isclose(ref["time"], m["t"], rtol=0, atol=1e-9))[-1]
        for name in names[1:]:
            y = "y_" + name[2:]
            assert m[y] == ref[y][row].item(), (m["t"], y)
    assert len({m["y_" + names[1][2:]] for m in messages}) >= 4  # the input moved the output


def test_a_bad_input_file_is_refused_in_one_line(fmu, tmp_path):
    version, path = fmu
    real = "Float64" if version == 3 else "Real"
    cases = {"time,u_nothing\n0,1\n": "column 'u_nothing' is not an input of the FMU",
             f"t,u_{real}\n0,1\n": "its first column must be the time",
             f"time,u_{real}\n1,1\n0,2\n": "the times must be finite and non-decreasing",
             f"time,u_{real}\n0,x\n": "line 2: a value that is no number",
             "time,u_Enumeration\n0,5\n": "not one of its items"}
    for k, (text, said) in enumerate(cases.items()):
        table = tmp_path / f"bad{k}.csv"
        table.write_text(text)
        with pytest.raises(DescriptionError, match=said.replace("(", r"\(")) as err:
            Execution(System(TICK, [Instance("e", path, input_file=table)]))
        assert "\n" not in str(err.value)


def test_step_sets_the_step_of_a_standard_package_and_only_of_one(fmu, tmp_path, capsys):
    """--step 0.05 on a package that declares no step: the run steps at 0.05 s (said), FMPy's result at its 0.05 s
    output interval; a package or a JSON file that declares its step refuses --step in one line."""
    from tiltload.master.app.cli import main

    version, path = fmu
    package = _standard_package(tmp_path, path, stop=0.2)
    code = main(["run", "--system", str(package), "--step", "0.05", "--out", str(tmp_path / "out"), "--no-plots"])
    said = capsys.readouterr()
    assert code == 0, said
    assert "no step annotation; step 0.05 s (--step, every FMU at it; declared: e 0.1 s)" in said.out
    messages = _logged(next((tmp_path / "out").rglob("*.mcap")), "e")
    ref = simulate_fmu(str(path), stop_time=0.2, output_interval=0.05)
    assert [m["t"] for m in messages] == pytest.approx(list(ref["time"]), abs=1e-12)
    for m, row in zip(messages, ref):
        assert all(m[f"y_{t}"] == row[f"y_{t}"].item() for t in _types(version))
    description = tmp_path / "s.json"
    description.write_text(json.dumps({"tick": TICK, "instances": [{"name": "e", "fmu": str(path)}]}))
    code = main(["run", "--system", str(description), "--step", "0.05", "--out", str(tmp_path / "bad"), "--quiet"])
    said = capsys.readouterr().err.strip()
    assert code == 2 and "declares its tick" in said and len(said.splitlines()) == 1


def test_the_command_line_s_input_file_drives_a_system_file_s_instance(tmp_path, capsys):
    """run --system s.json --input-file e=inputs.csv: the log equals FMPy's simulate_fmu(input=...) of the FMU."""
    from fmpy.util import read_csv
    from tiltload.master.app.cli import main

    path = every_type_fmu(tmp_path, 2)
    names, rows = _table(2)
    csv = tmp_path / "inputs.csv"
    csv.write_text(",".join(names) + "\n" + "\n".join(",".join(repr(x) for x in row) for row in rows) + "\n")
    description = tmp_path / "s.json"
    description.write_text(json.dumps({"tick": TICK, "instances": [{"name": "e", "fmu": str(path),
                                                                     "parameters": {"p_Real": 0.25}}]}))
    code = main(["run", "--system", str(description), "--stop-time", "0.5", "--input-file", f"e={csv}",
                 "--out", str(tmp_path / "out"), "--no-plots", "--quiet"])
    assert code == 0, capsys.readouterr()
    log = next((tmp_path / "out").rglob("*.mcap"))
    assert "inputs-inputs" in log.name
    ref = simulate_fmu(str(path), stop_time=0.5, output_interval=TICK, start_values={"p_Real": 0.25}, input=read_csv(csv))
    messages = _logged(log, "e")
    assert [m["t"] for m in messages] == pytest.approx(list(ref["time"]), abs=1e-12)
    for m, row in zip(messages, ref):
        assert all(m[f"y_{t}"] == row[f"y_{t}"].item() for t in FMI2_TYPES)
    code = main(["run", "--input-file", f"e={csv}", "--quiet"])
    said = capsys.readouterr().err.strip()
    assert code == 2 and "--input-file is for --system" in said and len(said.splitlines()) == 1


def test_a_64_bit_output_beyond_what_a_double_holds_is_an_error_naming_it(tmp_path):
    """Int64 travels as a double, exact within +-2^53: a value beyond is not rounded in silence."""
    path = every_type_fmu(tmp_path, 3)
    res = run_system(System(TICK, [Instance("e", path, parameters={"p_Int64": 2**60})]), 0.3, tmp_path / "run.mcap",
                     progress=False)
    assert res.error is not None and "Int64 output y_Int64 = 1152921504606846976 is beyond +-2^53" in res.error


@pytest.mark.parametrize("isolated", [False, True])
def test_string_and_binary_outputs_are_logged_with_their_type(tmp_path, isolated):
    """y_String is p_String after an even number of steps and u_String after an odd one; y_Binary the same of the
    Binaries with its first byte plus the count (every_type3.c; FMPy records neither type, so the model is the
    reference). Logged as JSON strings, the Binary in base64, at every time; in a worker process too (they come with
    its outputs on the pipe, isolation/wire.py), the same messages."""
    import base64

    path = every_type_fmu(tmp_path, 3)
    values = {"p_String": "even", "u_String": "odd", "p_Binary": "0a0b", "u_Binary": "ff01"}
    system = System(TICK, [Instance("e", path, parameters=values)])
    res = run_system(system, 0.3, tmp_path / "run.mcap", progress=False,
                     isolate=(lambda fmu, md: True) if isolated else None)
    assert res.error is None
    messages = _logged(tmp_path / "run.mcap", "e")
    assert [m["t"] for m in messages] == pytest.approx([0.0, 0.1, 0.2, 0.3])
    assert [m["y_String"] for m in messages] == ["even", "odd", "even", "odd"]
    binaries = [base64.b64decode(m["y_Binary"]) for m in messages]
    assert binaries == [bytes([0x0A, 0x0B]), bytes([0x00, 0x01]), bytes([0x0C, 0x0B]), bytes([0x02, 0x01])]


def test_an_ssp_export_of_a_system_with_an_input_file_is_refused(tmp_path):
    from tiltload.master.engine.ssp.export import export

    path = every_type_fmu(tmp_path, 2)
    table = tmp_path / "in.csv"
    table.write_text("time,u_Real\n0,1\n")
    system = System(TICK, [Instance("e", path, input_file=table)])
    with pytest.raises(DescriptionError, match="e: its input file .* has no place in an SSP package"):
        export(system, tmp_path / "x.ssp", 1.0)
    assert not (tmp_path / "x.ssp").exists()

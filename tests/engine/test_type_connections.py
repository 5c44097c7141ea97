"""Connections across the engine's arrays and of Strings and Binaries (issue 64): every lossless conversion FmiType.holds
accepts between two types of different carriers (whole numbers into Float32/Float64, UInt32, Int64, UInt64) reaches
its input exactly at every step and at t = 0, in process, in a worker process (FMI 3.0 over the pipe, FMI 2.0 over
the shared-memory link) and with a delay; a String or Binary output feeds an input of its type. The source's log equals
FMPy's simulate_fmu of the same FMU; a sink (its parameters 0: y = u) logs the source's values, converted exactly."""

from __future__ import annotations

import base64

import numpy as np
import pytest
from fmpy import simulate_fmu
from support.every_type_fmu import every_type_fmu
from tiltload.master.engine.fmi.model_description import FMI_TYPES
from tiltload.master.engine.log import reader as log_reader
from tiltload.master.engine.run import run_system
from tiltload.master.engine.system import Connection, Instance, System

TICK = 0.1
# the source's values: beyond the narrower types' ranges where a type allows (a wrong conversion shows)
SOURCE = {"p_Int8": -7, "u_Int8": 100, "p_UInt8": 11, "u_UInt8": 200, "p_Int16": -300, "u_Int16": 30000,
          "p_UInt16": 600, "u_UInt16": 60000, "p_Int32": -70000, "u_Int32": 2**30 + 1, "p_Float64": 0.3}
WHOLE = ("Int8", "UInt8", "Int16", "UInt16", "Int32")  # carried as Integer
WIDE = ("Float32", "Float64", "UInt32", "Int64", "UInt64")  # carried as Real


def conversions() -> list[tuple[str, str]]:
    """Every lossless conversion between two types of different carriers, as the type table says (not a list of ours)."""
    return [(s, d) for s in FMI_TYPES for d in FMI_TYPES if "Enumeration" not in (s, d) and FMI_TYPES[s].carrier and
            FMI_TYPES[d].carrier and FMI_TYPES[s].carrier != FMI_TYPES[d].carrier and FMI_TYPES[d].holds(FMI_TYPES[s])]


def test_the_conversions_are_those_of_whole_numbers_into_wider_types():
    pairs = conversions()
    assert {s for s, _ in pairs} == set(WHOLE) and {d for _, d in pairs} == set(WIDE)
    assert ("Int32", "Float64") in pairs and ("UInt8", "UInt64") in pairs and ("Int32", "Float32") not in pairs
    assert ("Int8", "UInt32") not in pairs and len(pairs) == 18


def _logged(log, topic: str) -> list[dict]:
    return log_reader.read(log)[f"/{topic}"]


def _fmpy_equals(path, messages: list[dict], outputs, values: dict, stop: float) -> None:
    ref = simulate_fmu(str(path), stop_time=stop, output_interval=TICK, start_values=values)
    assert [m["t"] for m in messages] == pytest.approx(list(ref["time"]), abs=1e-12)
    for m, row in zip(messages, ref):
        for name in outputs:
            assert m[name] == row[name].item(), (m["t"], name)


def _exact(value, target: str):
    """The value as the target type holds it: the C conversion of a whole number (a Float32's through numpy's)."""
    if target == "Float32":
        return float(np.float32(value))
    return float(value) if target == "Float64" else int(value)


def _isolate(mode: str):
    return (lambda fmu, md: True) if mode == "isolated" else None


@pytest.mark.parametrize("mode", ["in process", "isolated"])
def test_every_lossless_conversion_across_carriers_reaches_its_input_exactly(tmp_path, mode):
    """FMI 3.0: one source, a sink per whole-number type fed into every wider type that holds it (18 connections):
    each sink's y_T (= u_T) equals the source's y_S converted, at every logged time, t = 0 included (a worker takes the
    connected values with its init request and sets them in Initialization Mode); the source equals FMPy's result."""
    path = every_type_fmu(tmp_path, 3)
    pairs = conversions()
    sinks = {s: [d for s2, d in pairs if s2 == s] for s in WHOLE}
    instances = [Instance("a", path, parameters=SOURCE)]
    instances += [Instance(f"b_{s}", path, parameters={f"p_{d}": 0 for d in ds}) for s, ds in sinks.items()]
    system = System(TICK, instances, auto_connect=False)
    system.connections = [Connection(f"a.y_{s}", f"b_{s}.u_{d}") for s, ds in sinks.items() for d in ds]
    res = run_system(system, 0.3, tmp_path / "run.mcap", progress=False, isolate=_isolate(mode))
    assert res.error is None
    a = _logged(tmp_path / "run.mcap", "a")
    _fmpy_equals(path, a, [f"y_{s}" for s in WHOLE], SOURCE, 0.3)
    checked = 0
    for s, ds in sinks.items():
        b = _logged(tmp_path / "run.mcap", f"b_{s}")
        assert [m["t"] for m in b] == [m["t"] for m in a]
        for ma, mb in zip(a, b):
            for d in ds:
                expected = _exact(ma[f"y_{s}"], d)
                assert mb[f"y_{d}"] == expected and type(mb[f"y_{d}"]) is type(expected), (mode, ma["t"], s, d)
                checked += 1
    assert checked == 18 * 4


@pytest.mark.parametrize("mode", ["in process", "isolated"])
def test_an_fmi2_integer_feeds_a_real_exactly_with_and_without_a_delay(tmp_path, mode):
    """FMI 2.0 (the C loop calls it itself; isolated, over the shared-memory link): a.y_Integer -> b.u_Real and, a tick
    late, -> c.u_Real; b logs a's values as doubles, c those of the tick before (its first two: a's at t = 0)."""
    path = every_type_fmu(tmp_path, 2)
    values = {"p_Integer": -70001, "u_Integer": 2**31 - 1 - 3 * 70001}
    system = System(TICK, [Instance("a", path, parameters=values), Instance("b", path, parameters={"p_Real": 0}),
                           Instance("c", path, parameters={"p_Real": 0})], auto_connect=False)
    system.connections = [Connection("a.y_Integer", "b.u_Real"), Connection("a.y_Integer", "c.u_Real", 1)]
    res = run_system(system, 0.4, tmp_path / "run.mcap", progress=False, isolate=_isolate(mode))
    assert res.error is None
    a, b, c = (_logged(tmp_path / "run.mcap", n) for n in "abc")
    _fmpy_equals(path, a, ["y_Integer"], values, 0.4)
    ya = [m["y_Integer"] for m in a]
    assert len(set(ya)) == 5 and min(ya) > 2**30  # far beyond 2^24: a float32 on the way would show
    assert [m["y_Real"] for m in b] == [float(y) for y in ya]
    assert [m["y_Real"] for m in c] == [float(y) for y in [ya[0], *ya[:-1]]]
    assert all(type(m["y_Real"]) is float for m in b + c)


def test_a_fault_on_a_converted_input_acts_on_the_target_s_values(tmp_path):
    """A bias on a Float64 input fed by an Int32 (from 0.15 s): the input's values are the target's, biased as any
    Float64 input is (the sink's y = u + 0.5 from its first step the fault is active at)."""
    from tiltload.master.engine.faults.schedule import Fault

    path = every_type_fmu(tmp_path, 2)
    values = {"p_Integer": 3, "u_Integer": 5}
    system = System(TICK, [Instance("a", path, parameters=values), Instance("b", path, parameters={"p_Real": 0})],
                    auto_connect=False, faults=[Fault("bias", ["b.u_Real"], 0.15, value=0.5)])
    system.connections = [Connection("a.y_Integer", "b.u_Real")]
    assert run_system(system, 0.4, tmp_path / "run.mcap", progress=False).error is None
    a, b = _logged(tmp_path / "run.mcap", "a"), _logged(tmp_path / "run.mcap", "b")
    assert [m["y_Real"] for m in b] == [m["y_Integer"] + (0.5 if m["t"] > 0.25 else 0.0) for m in a]


def _texts_expected(p: str, u: str, pb: bytes, ub: bytes, feeds, steps: int) -> tuple[list, list]:
    """every_type3.c's y_String and y_Binary after j = 0..steps steps: p after an even j, u after an odd one (feeds(j):
    the u set before the step j - 1, None for the FMU's own), the Binary's first byte + j."""
    strings, binaries = [], []
    for j in range(steps + 1):
        s, b = (p, pb) if j % 2 == 0 else (feeds(j) or (u, ub))
        strings.append(s)
        binaries.append(bytes([(b[0] + j) % 256, *b[1:]]))
    return strings, binaries


@pytest.mark.parametrize("mode", ["in process", "isolated"])
def test_a_string_and_a_binary_output_feed_inputs_of_their_type(tmp_path, mode):
    """a.y_String -> b.u_String and a.y_Binary -> b.u_Binary, and the same a tick late into c: b and c log the values
    the model gives with those inputs (every_type3.c: FMPy records neither type), at every logged time, in process and
    with every FMU in a worker process (whose String and Binary outputs are logged as in process)."""
    path = every_type_fmu(tmp_path, 3)
    source = {"p_String": "even", "u_String": "odd", "p_Binary": "0a0b", "u_Binary": "ff01"}
    system = System(TICK, [Instance("a", path, parameters=source),
                           Instance("b", path, parameters={"p_String": "B", "p_Binary": "b0"}),
                           Instance("c", path, parameters={"p_String": "C", "p_Binary": "c0"})], auto_connect=False)
    system.connections = [Connection(f"a.y_{t}", f"{n}.u_{t}", d) for t in ("String", "Binary") for n, d in (("b", 0),
                                                                                                         ("c", 1))]
    res = run_system(system, 0.4, tmp_path / "run.mcap", progress=False, isolate=_isolate(mode))
    assert res.error is None
    logs = {n: _logged(tmp_path / "run.mcap", n) for n in "abc"}
    for n in "abc":
        assert [m["t"] for m in logs[n]] == pytest.approx([0.0, 0.1, 0.2, 0.3, 0.4])
    got = {n: ([m["y_String"] for m in logs[n]], [base64.b64decode(m["y_Binary"]) for m in logs[n]]) for n in "abc"}
    a = _texts_expected("even", "odd", bytes.fromhex("0a0b"), bytes.fromhex("ff01"), lambda j: None, 4)
    assert got["a"] == a
    assert a[0] == ["even", "odd", "even", "odd", "even"]  # the source's values change: a wrong feed shows

    def fed(delay):  # a's outputs after its step j - delay (a steps first in a tick), the input of step j - 1
        return lambda j: (a[0][j - delay], a[1][j - delay])

    assert got["b"] == _texts_expected("B", "", b"\xb0", b"", fed(0), 4)
    assert got["c"] == _texts_expected("C", "", b"\xc0", b"", fed(1), 4)


def test_string_and_binary_inputs_hold_their_connected_values_at_t_0(tmp_path):
    """Set in Initialization Mode from the source's values there (the source's y = its p at k = 0)."""
    from tiltload.master.engine.execution import Execution

    path = every_type_fmu(tmp_path, 3)
    system = System(TICK, [Instance("b", path), Instance("a", path, parameters={"p_String": "zero", "p_Binary": "0102"})],
                    auto_connect=False)
    system.connections = [Connection("a.y_String", "b.u_String"), Connection("a.y_Binary", "b.u_Binary")]
    ex = Execution(system)
    ex.instantiate()
    try:
        fmu = ex.instances["b"]._fmpy
        assert fmu.getString([212]) in (["zero"], [b"zero"]) and fmu.getBinary([213]) == [b"\x01\x02"]
        assert ex.loop.paths["b"] == "callback: FMI 3.0 types the kernel does not convert"
    finally:
        ex.close()


def test_a_served_fmu_s_strings_and_binaries_are_logged_and_connected_as_in_process(tmp_path):
    """The source on `tiltload serve` (the same worker, on a socket): its String and Binary outputs logged, and fed into
    an FMU in this process, message for message as when both run in this process; an Int16 into a Float64 too."""
    from support.remote import ServerProcess, token_file

    folder = tmp_path / "served"
    folder.mkdir()
    path = every_type_fmu(folder, 3)
    token = token_file(tmp_path)
    source = {"p_String": "even", "u_String": "odd", "p_Binary": "0a0b", "u_Binary": "ff01", "p_Int16": -300,
              "u_Int16": 30000}
    logs = {}
    server = ServerProcess(folder, token)
    try:
        for where in ("local", "served"):
            system = System(TICK, [Instance("a", path, parameters=source), Instance("b", path, parameters={
                "p_String": "B", "p_Binary": "b0", "p_Float64": 0})], auto_connect=False)
            if where == "served":
                system.instance("a").remote, system.instance("a").token_file = server.address, token
            system.connections = [Connection(f"a.y_{t}", f"b.u_{t}") for t in ("String", "Binary")]
            system.connections.append(Connection("a.y_Int16", "b.u_Float64"))
            assert run_system(system, 0.3, tmp_path / f"{where}.mcap", progress=False).error is None
            logs[where] = {n: _logged(tmp_path / f"{where}.mcap", n) for n in "ab"}
    finally:
        server.stop()
    assert logs["served"]["a"][1]["y_String"] == "odd" and logs["served"]["b"][1]["y_String"] == "odd"
    assert logs["served"]["b"][1]["y_Float64"] == float(logs["served"]["a"][1]["y_Int16"]) == 29700.0
    assert logs["served"] == logs["local"]


def test_an_ssp_export_of_converting_string_and_binary_connections_runs_back_as_the_system_file(tmp_path, capsys):
    """`ssp export` (SSP 2.0, FMI 3.0) of a system with an Int32 -> Float64, a UInt8 -> UInt64 and the String and Binary
    connections: `run --system` of the package logs what the system file's run logs, message for message."""
    import json

    from tiltload.master.app.cli import main

    path = every_type_fmu(tmp_path, 3)
    description = tmp_path / "types.json"
    description.write_text(json.dumps({
        "tick": TICK, "auto_connect": False,
        "instances": [{"name": "a", "fmu": str(path), "parameters": {**SOURCE, "p_String": "even", "p_Binary": "0a0b"}},
                      {"name": "b", "fmu": str(path), "parameters": {"p_Float64": 0, "p_UInt64": 0}}],
        "connections": [{"source": f"a.y_{s}", "target": f"b.u_{d}"} for s, d in
                        (("Int32", "Float64"), ("UInt8", "UInt64"), ("String", "String"), ("Binary", "Binary"))]}))
    package = tmp_path / "types.ssp"
    assert main(["ssp", "export", str(package), "--system", str(description), "--stop-time", "0.3",
                 "--schedule", "ordered"]) == 0, capsys.readouterr()
    logs = {}
    for name, system in (("json", description), ("ssp", package)):
        code = main(["run", "--system", str(system), "--stop-time", "0.3", "--out", str(tmp_path / name), "--no-plots",
                     "--quiet"])
        assert code == 0, capsys.readouterr()
        log = next((tmp_path / name).rglob("*.mcap"))
        logs[name] = {n: _logged(log, n) for n in "ab"}
    assert logs["ssp"] == logs["json"]
    b = logs["ssp"]["b"]
    assert [m["y_Float64"] for m in b] == [float(m["y_Int32"]) for m in logs["ssp"]["a"]]
    assert [m["y_String"] for m in b][1::2] == [m["y_String"] for m in logs["ssp"]["a"]][1::2]


def test_a_restart_feeds_strings_again_and_a_fault_on_a_string_is_refused_in_one_line(tmp_path):
    """Execution.restart (fmi3Reset, a campaign's next run): the String and Binary inputs are set again from the
    sources' values, the second run's log equals the first's; a fault on a String or Binary variable is refused."""
    from tiltload.master.engine.errors import DescriptionError
    from tiltload.master.engine.execution import Execution
    from tiltload.master.engine.faults.schedule import Fault
    from tiltload.master.engine.log.logger import McapLogger

    path = every_type_fmu(tmp_path, 3)
    system = System(TICK, [Instance("a", path, parameters={"p_String": "even", "u_String": "odd"}),
                           Instance("b", path, parameters={"p_String": "B"})], auto_connect=False)
    system.connections = [Connection("a.y_String", "b.u_String", 1), Connection("a.y_Binary", "b.u_Binary")]
    ex = Execution(system, [McapLogger(tmp_path / "first.mcap")])
    ex.instantiate()
    try:
        ex.end(0.3)
        ex.finish()
        ex.restart(observers=[McapLogger(tmp_path / "second.mcap")])
        ex.end(0.3)
    finally:
        ex.close()
    first = _logged(tmp_path / "first.mcap", "b")
    assert [m["y_String"] for m in first] == ["B", "even", "B", "even"]  # a's after step j - 1 - 1 at odd j: even
    assert _logged(tmp_path / "second.mcap", "b") == first
    for target in ("b.u_String", "a.y_Binary"):
        faulty = System(TICK, system.instances, auto_connect=False, faults=[Fault("override", [target], 0.1, value=1)])
        with pytest.raises(DescriptionError, match=f"{target} is a (String|Binary); faults act on numbers and Booleans"):
            Execution(faulty)

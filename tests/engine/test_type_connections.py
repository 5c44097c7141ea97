"""Connections across the engine's arrays and of Strings and Binaries (issue 64): every lossless conversion FmiType.holds
accepts between two types of different carriers (whole numbers into Float32/Float64, UInt32, Int64, UInt64) reaches
its input exactly at every step and at t = 0, in process, in a worker process (FMI 3.0 over the pipe, FMI 2.0 over
the shared-memory link) and with a delay; a String or Binary output feeds an input of its type. The source's log equals
FMPy's simulate_fmu of the same FMU; a sink (its parameters 0: y = u) logs the source's values, converted exactly."""

from __future__ import annotations

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
    each sink's y_T (= u_T) equals the source's y_S converted, at every logged time, t = 0 included in process; the
    source equals FMPy's result."""
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
                # a worker's sample at 0 is its outputs after its initialization, the inputs' start values (as for a
                # connection of one type: the connected values reach it with its first step, execution._propagate)
                expected = _exact(ma[f"y_{s}"] if mode == "in process" or ma["t"] > 0 else 0, d)
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
    at_zero = [] if mode == "in process" else [0.0]  # a worker's sample at 0: its start values (see above)
    assert [m["y_Real"] for m in b] == at_zero + [float(y) for y in ya][len(at_zero):]
    assert [m["y_Real"] for m in c] == at_zero + [float(y) for y in [ya[0], *ya[:-1]]][len(at_zero):]
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

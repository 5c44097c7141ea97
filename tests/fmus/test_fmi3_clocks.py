"""The FMI 3.0 variants with clocks: the sensor suite (a periodic input clock per group, Table 5.8's periods) and the
controller (T_c), driven by hand through FMPy with the standard's co-simulation sequence: what they declare, the
clock rules of the layer, lazy partitions (inputs set after fmi3SetClock count; a change after a read runs the
partition again from the event's start), time events, and samples equal to the plain variant's bit for bit."""

from __future__ import annotations

import xml.etree.ElementTree as ET
import zipfile
from fractions import Fraction

import numpy as np
import pytest
from fmpy import read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi3 import fmi3Float64, fmi3IntervalQualifier, fmi3UInt64, fmi3ValueReference
from fmpy.validation import validate_fmu
from support import T
from support.fmi3_session import Session3, session3
from tiltload.controller_fmu.fmu.build import TC
from tiltload.sensor_fmu.fmu_variables import channel_names
from tiltload.sensor_fmu.suite import GROUPS

CLOCKED = ("TiltloadSensorsClocked", "TiltloadControllerClocked")


@pytest.fixture(scope="module")
def clocked(fmi3_fmus):
    from tiltload.master.app.loop.fmus import clocked_recipes, fmu_folder
    from tiltload.native_fmu.build import build

    folder = fmi3_fmus["TiltloadPlant"].parent
    assert folder == fmu_folder(folder.parent, 3)
    return {r.fmu_name[:-4]: build(r, folder, progress=lambda *_: None, fmi_version=3).path for r in clocked_recipes(("load",))}


def _clocks(fmu) -> dict[str, ET.Element]:
    with zipfile.ZipFile(fmu) as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
    return {e.get("name"): e for e in root.iter("Clock")}


# ---- what they declare ------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", CLOCKED)
def test_clocked_variants_validate_and_declare_event_mode(clocked, name):
    assert validate_fmu(str(clocked[name])) == []
    md = read_model_description(str(clocked[name]))
    assert md.coSimulation.hasEventMode and md.coSimulation.canHandleVariableCommunicationStepSize
    for v in md.modelVariables:
        if v.clocks:
            assert v.variability == "discrete" and v.causality in ("input", "output")
            assert all(k.type == "Clock" for k in v.clocks)
    clocked_outputs = [v for v in md.modelVariables if v.causality == "output" and v.clocks]
    assert clocked_outputs and not {u.variable.name for u in md.initialUnknowns} & {v.name for v in clocked_outputs}


def test_each_sensor_group_has_a_clock_of_its_table_5_8_period(clocked):
    clocks = _clocks(clocked["TiltloadSensorsClocked"])
    md = read_model_description(str(clocked["TiltloadSensorsClocked"]))
    variables = {v.name: v for v in md.modelVariables}
    assert list(clocks) == [f"{g.name}_clock" for g in GROUPS]
    for g in GROUPS:
        e = clocks[f"{g.name}_clock"]
        assert e.get("causality") == "input" and e.get("intervalVariability") == "constant"
        assert float(e.get("intervalDecimal")) == g.period and float(e.get("shiftDecimal")) == 0.0
        assert Fraction(int(e.get("intervalCounter")), int(e.get("resolution"))) == Fraction(str(g.period))
        for n in channel_names(g):
            assert [k.name for k in variables[n].clocks] == [f"{g.name}_clock"]
        assert not variables[f"{g.name}_new"].clocks  # the flags are discrete outputs of every Event Mode
    assert not any(n.endswith("_period") for n in variables)  # the clocks are the periods


def test_the_controller_runs_on_one_clock_of_interval_tc(clocked):
    clocks = _clocks(clocked["TiltloadControllerClocked"])
    assert list(clocks) == ["control_clock"] and float(clocks["control_clock"].get("intervalDecimal")) == TC
    md = read_model_description(str(clocked["TiltloadControllerClocked"]))
    ports = [v for v in md.modelVariables if v.causality in ("input", "output") and v.type != "Clock"]
    assert ports and all([k.name for k in v.clocks] == ["control_clock"] for v in ports)


# ---- the clocked sequence, by hand -------------------------------------------------------------------------
def _due(groups, k: int) -> list[int]:
    return [j for j, g in enumerate(groups) if k % round(g.period / T) == 0]


def _clock_vrs(s: Session3) -> list[int]:
    return [s.vr[f"{g.name}_clock"] for g in GROUPS]


def _tick(s: Session3, k: int, state: dict, outputs: list[str], first: bool = False, clocks=None) -> dict:
    """One tick of the standard's sequence: Event Mode, inputs, the due clocks, their clocked outputs, update."""
    if not first:
        s.fmu.enterEventMode()
    s.set(**state)
    due = _due(GROUPS, k) if clocks is None else clocks
    vrs = _clock_vrs(s)
    s.fmu.setClock([vrs[j] for j in due], [True] * len(due))
    got = {n: s.get(n)[0] for j in due for n in channel_names(GROUPS[j]) if n in outputs}
    need, terminate, _, _, next_defined, next_time = s.fmu.updateDiscreteStates()
    assert not need and not terminate
    s.fmu.enterStepMode()
    status, event, terminate, early, last = s.do_step(k * T, T)
    assert status == 0 and not terminate and not early and last == pytest.approx((k + 1) * T, abs=1e-12)
    got.update({n: s.get(n)[0] for n in outputs if n.endswith("_new") or n.startswith("exact_")})
    return got


def test_clocked_sensors_sample_as_the_plain_sensors_bit_for_bit(fmi3_fmus, clocked):
    rng = np.random.default_rng(5)
    states = [dict(zip(["x", "y", "z", "phi"], rng.normal(0, 0.1, 4))) for _ in range(200)]
    held = [n for g in GROUPS for n in channel_names(g)]
    flags = [f"{g.name}_new" for g in GROUPS]
    with session3(fmi3_fmus["TiltloadSensors"], instance="plain") as plain, \
            session3(clocked["TiltloadSensorsClocked"], instance="clocked", event_mode=True) as clk:
        for s in (plain, clk):
            s.set(seed=11)
        plain.fmu.exitInitializationMode()
        clk.fmu.exitInitializationMode()  # now in Event Mode: the first tick's
        last = {}
        for k, state in enumerate(states):
            plain.set(**state)
            assert plain.do_step(k * T, T)[0] == 0
            expected = dict(zip(held + flags, plain.get(*held, *flags)))
            got = _tick(clk, k, state, held + flags, first=k == 0)
            last.update({n: v for n, v in got.items() if n in held})
            for n in held:
                assert last[n] == expected[n], (k, n)  # bit for bit, held between its clock's ticks
            for g, n in zip(GROUPS, flags):
                assert got[n] == expected[n] == (k % round(g.period / T) == 0), (k, n)


def test_clock_rules_of_the_layer(clocked):
    sensors = clocked["TiltloadSensorsClocked"]
    with pytest.raises(Exception, match="Failed to instantiate"):
        Session3(sensors, instance="no_event_mode", event_mode=False)
    with session3(sensors, instance="rules", event_mode=True) as s:
        vrs = _clock_vrs(s)
        vr = (fmi3ValueReference * 2)(vrs[0], vrs[1])
        intervals, qualifiers = (fmi3Float64 * 2)(), (fmi3IntervalQualifier * 2)()
        s.fmu.getIntervalDecimal(vr, intervals, qualifiers)  # Initialization Mode: the declared constant intervals
        assert list(intervals) == [GROUPS[0].period, GROUPS[1].period] and list(qualifiers) == [1, 1]  # Unchanged
        counters, resolutions = (fmi3UInt64 * 2)(), (fmi3UInt64 * 2)()
        s.fmu.getIntervalFraction(vr, counters, resolutions, qualifiers)
        assert [Fraction(c, r) for c, r in zip(counters, resolutions)] == [Fraction("0.012"), Fraction("0.12")]
        with pytest.raises(FMICallException):
            s.fmu.setIntervalDecimal(vr, intervals)
        assert s.said("are constant")
    with session3(sensors, instance="inactive", event_mode=True) as s:
        s.fmu.exitInitializationMode()
        with pytest.raises(FMICallException):
            s.get("meas_x_B")  # Event Mode, but gps_clock is not active
        assert s.said("meas_x_B is clocked by gps_clock, which is not active (activate it with fmi3SetClock first)")
    with session3(sensors, instance="step", event_mode=True) as s:
        s.fmu.exitInitializationMode()
        s.fmu.updateDiscreteStates()
        s.fmu.enterStepMode()
        with pytest.raises(FMICallException):
            s.get("meas_x_B")
        assert s.said("clocked variables are accessible in Event Mode only")
    with session3(sensors, instance="setclock", event_mode=True) as s:
        s.fmu.exitInitializationMode()
        s.fmu.updateDiscreteStates()
        s.fmu.enterStepMode()
        with pytest.raises(FMICallException):
            s.fmu.setClock([_clock_vrs(s)[1]], [True])
        assert s.said("fmi3SetClock is not allowed in step mode")
    with session3(sensors, instance="deactivate", event_mode=True) as s:
        s.fmu.exitInitializationMode()
        s.fmu.setClock([_clock_vrs(s)[1]], [True])
        with pytest.raises(FMICallException):
            s.fmu.setClock([_clock_vrs(s)[1]], [False])
        assert s.said("gps_clock cannot be deactivated (canBeDeactivated is false)")
    with session3(clocked["TiltloadControllerClocked"], instance="clocked_input", event_mode=True) as s:
        s.fmu.exitInitializationMode()
        with pytest.raises(FMICallException):
            s.set(x_ref=1.0)  # clocked by control_clock, not active
        assert s.said("x_ref is clocked by control_clock, which is not active")


def test_inputs_set_after_the_clock_count_and_a_later_change_reruns_the_partition(clocked):
    """The sample is taken at the first read, from the inputs then; a change after it takes the sample again."""
    def baro(*states):
        with session3(clocked["TiltloadSensorsClocked"], instance="lazy", event_mode=True) as s:
            s.fmu.exitInitializationMode()
            s.fmu.setClock([s.vr["baro_clock"]], [True])
            out = []
            for z in states:  # set after fmi3SetClock
                s.set(z=z)
                out.append(s.get("meas_z_B")[0])
            return out
    (only,), (first, again) = baro(-3.0), baro(-2.5, -3.0)
    assert again == only and first != only and first - only == pytest.approx(0.5, abs=1e-12)  # z_B follows z


# the commands, and the ZSE's centre, interval hull (a sum over every generator) and size
TICK_OUTPUTS = ("f_R", "f_L", "tau_R", "tau_L", "est_x", "est_x_lo", "est_z_hi", "zse_G_frobenius", "zse_generators")


def _controller_tick(s: Session3, inputs: dict, first: bool) -> list[float]:
    if not first:
        s.fmu.enterEventMode()
    s.fmu.setClock([s.vr["control_clock"]], [True])
    s.set(**inputs)
    out = s.get(*TICK_OUTPUTS)
    s.fmu.updateDiscreteStates()
    s.fmu.enterStepMode()
    assert s.do_step(s.get("time")[0], T)[0] == 0
    return out


def test_a_rerun_starts_from_the_state_the_event_began_with(clocked):
    """The controller's estimator advances in its partition: run with wrong inputs, correct them, read again; the
    commands and the ZSE's bounds equal an instance that only ever saw the correct inputs, tick after tick: past the
    first order reduction (1725 generators) and the Gram matrix's resynchronization from the generators (64 steps), so
    the generator buffers the rerun's copy leaves out (controller_model.h) are as the event found them."""
    fmu = clocked["TiltloadControllerClocked"]
    good = lambda k: {"x_ref": 0.01 * k, "meas_z_B": -0.02 * k, "gps_new": k % 10 == 0}  # noqa: E731
    with session3(fmu, instance="straight", event_mode=True) as a, session3(fmu, instance="rerun", event_mode=True) as b:
        a.fmu.exitInitializationMode()
        b.fmu.exitInitializationMode()
        for k in range(80):
            expected = _controller_tick(a, good(k), k == 0)
            if k:
                b.fmu.enterEventMode()
            b.fmu.setClock([b.vr["control_clock"]], [True])
            b.set(x_ref=5.0, meas_z_B=3.0)
            b.get("f_R")  # the partition ran with the wrong inputs
            b.set(**good(k))
            assert b.get(*TICK_OUTPUTS) == expected
            b.fmu.updateDiscreteStates()
            b.fmu.enterStepMode()
            assert b.do_step(k * T, T)[0] == 0
    assert expected[-1] == 75 * 23  # the order reduction was at work (75 n generators)


def test_a_raised_flag_asks_for_the_next_event(clocked):
    """Only the GPS ticks at t = 0 here: gps_new is raised, and the FMU asks for an Event Mode one tick later (a time
    event, and eventHandlingNeeded from the step), where no clock ticks and the flag goes down."""
    with session3(clocked["TiltloadSensorsClocked"], instance="flags", event_mode=True) as s:
        s.fmu.exitInitializationMode()
        s.fmu.setClock([s.vr["gps_clock"]], [True])
        assert s.get("gps_new", "baro_new") == [True, False]
        _, _, _, _, next_defined, next_time = s.fmu.updateDiscreteStates()
        assert next_defined and next_time == T
        s.fmu.enterStepMode()
        status, event, *_ = s.do_step(0.0, T)
        assert status == 0 and event
        assert s.get("gps_new") == [True]  # held over the step
        s.fmu.enterEventMode()
        _, _, _, _, next_defined, _ = s.fmu.updateDiscreteStates()
        assert not next_defined and s.get("gps_new") == [False]
        s.fmu.enterStepMode()
        assert s.do_step(T, T)[:2] == (0, False)


def test_serialized_state_of_a_clocked_fmu_continues_bit_for_bit(clocked):
    held = [n for g in GROUPS for n in channel_names(g)]

    def run(s, k0, k1):
        return [_tick(s, k, {"x": 0.001 * k}, held, first=k == 0) for k in range(k0, k1)]
    with session3(clocked["TiltloadSensorsClocked"], instance="whole", event_mode=True) as s:
        s.fmu.exitInitializationMode()
        run(s, 0, 40)
        blob = s.fmu.serializeFMUState(s.fmu.getFMUState())  # in Step Mode, between two ticks
        rest = run(s, 40, 80)
    with session3(clocked["TiltloadSensorsClocked"], instance="restored", event_mode=True) as s:
        s.fmu.setFMUState(s.fmu.deserializeFMUState(blob))
        assert run(s, 40, 80) == rest

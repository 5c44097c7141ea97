"""A waypoint file (docs/examples/mission.csv, not a built-in) flown in closed loop by both designs, and the same file
giving the same reference in libcosim and Ecos as in our master."""

from __future__ import annotations

import zipfile

import numpy as np
import pytest
from support import ROOT
from tiltload.controller_fmu.design.cache import cache_root
from tiltload.master.app.cli import main
from tiltload.master.app.loop.inputs import READER
from tiltload.master.app.loop.thesis import default_system, loop_metrics
from tiltload.master.engine.log import reader as log_reader
from tiltload.master.engine.run import run_system
from tiltload.master.engine.ssp.load import load
from tiltload.master.engine.ssp.schema import PARAMETER_SET
from tiltload.scenario_fmu import choice, twin
from tiltload.scenario_fmu.wind import read_wind

MISSION = ROOT / "docs" / "examples" / "mission.csv"
TICK = 0.012
REF = ("x_ref", "y_ref", "z_ref", "vx_ref", "vy_ref", "vz_ref", "ax_ref", "ay_ref", "az_ref", "psi_ref", "psi_dot_ref")


@pytest.mark.parametrize("scenario", ["fsi", "zse"])
@pytest.mark.parametrize("controller", ["dlqr", "mixed"])
def test_the_mission_is_flown_by_both_designs(fmus, tmp_path, scenario, controller):
    """36 s: climb, a rectangle through a waypoint passed at speed, a 0.2 rad yaw turn, descent, with the thesis's gusts
    and a light Dryden turbulence on a 2 m/s wind (docs/examples/gusty_wind.yaml). Stable, on the path throughout,
    ISE printed (docs/test_bench.md has the table)."""
    mission = choice.resolve(str(MISSION), read=READER)
    wind = read_wind(ROOT / "docs" / "examples" / "gusty_wind.yaml", READER)
    system = default_system(fmus, scenario, mission, controller, seed=3, wind=wind)
    res = run_system(system, mission.duration, tmp_path / "mission.mcap", loop_metrics(), progress=False)
    assert res.error is None and res.ticks == 3000
    log = log_reader.read(res.log, topics=["/plant", "/scenario"])
    ref = {round(m["t"], 9): m for m in log["/scenario"]}
    err = np.array([[m[a] - ref[round(m["t"] - TICK, 9)][f"{a}_ref"] for a in "xyz"] for m in log["/plant"]
                    if round(m["t"] - TICK, 9) in ref])
    worst = np.abs(err).max(axis=0)
    print(f"{scenario} {controller}: " + ", ".join(f"{k} {v:.4g}" for k, v in res.metrics.items() if k.startswith("ISE"))
          + f"; worst |error| {worst.round(3)} m")
    assert worst.max() < (0.25 if scenario == "fsi" else 0.5)
    assert abs(err[-1]).max() < (0.05 if scenario == "fsi" else 0.2)  # back at the last waypoint
    assert res.metrics["ISE(x)"] < (0.1 if scenario == "fsi" else 0.3) and res.metrics["ISE(psi)"] < 0.02
    assert np.abs([m["wind_vy"] for m in log["/scenario"] if 11.5 < m["t"] < 13.5]).min() > 2  # the profile's gust blew


@pytest.fixture(scope="module")
def mission_package(pipeline_fmus, tmp_path_factory):
    fmus = pipeline_fmus["TiltloadPlant"].parent
    out = tmp_path_factory.mktemp("mission") / "mission.ssp"
    assert main(["ssp", "export", str(out), "--fmus", str(fmus), "--trajectory", str(MISSION), "--scenario", "fsi",
                 "--controller", "mixed", "--schedule", "jacobi", "--stop-time", repr(3000 * TICK)]) == 0
    return out


def test_the_same_file_gives_the_same_reference_in_libcosim_ecos_and_ours(mission_package, tmp_path):
    """The package carries the reference as the scenario FMU's parameters; libcosim and Ecos step it with the rest of
    the loop: every tick's reference equals the Python twin of the C (which our master's FMU equals to the bit:
    tests/fmus/test_scenario_fmu.py) at that master's own clock, to the bit. (The clocks differ in the last bit:
    libcosim counts nanoseconds, Ecos adds steps; on the grid k * 0.012 s the values agree to 4e-13.)"""
    from ecospy import EcosSimulation
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver

    system, _, _ = load(mission_package, cache_root() / "ssp")
    parameters = system.instance("scenario").parameters
    with zipfile.ZipFile(system.instance("scenario").fmu) as z:  # the mission travels in the scenario FMU's resources
        (tmp_path / "knots.csv").write_bytes(z.read(f"resources/{parameters['waypoints_file']}"))
    parameters = {**parameters, "waypoints_file": str(tmp_path / "knots.csv")}

    def ours(times):
        expected = twin.evaluate(parameters, np.array(times))
        return np.c_[expected.p, expected.v, expected.a, expected.psi, expected.psi_dot]

    want = ours(np.arange(3000) * TICK)

    log_output_level(CosimLogLevel.ERROR)
    ex = CosimExecution.from_ssp_file(str(mission_package))
    observer = CosimObserver.create_last_value()
    ex.add_observer(observer)
    index = {s.name.decode(): s.index for s in ex.slave_infos()}["scenario"]
    refs = {v.name.decode(): v.reference for v in ex.slave_variables(index)}
    cosim, clock = [], []
    for _ in range(3000):
        clock.append(ex.status().current_time / 1e9)  # the doStep's t_k, from libcosim's nanoseconds
        assert ex.step()
        cosim.append(observer.last_real_values(index, [refs[n] for n in REF]))
    np.testing.assert_array_equal(np.array(cosim), ours(clock))
    np.testing.assert_allclose(np.array(cosim), want, rtol=0, atol=1e-12)

    sim = EcosSimulation(ssp_path=str(mission_package), step_size=TICK)
    try:
        sim.init(parameter_set=PARAMETER_SET)
        ecos, clock = [], []
        for _ in range(3000):
            clock.append(sim.get_time())
            sim.step(1)
            ecos.append([sim.get_real(f"scenario::{n}") for n in REF])
    finally:
        sim.terminate()
        sim.free()
    np.testing.assert_array_equal(np.array(ecos), ours(clock))
    np.testing.assert_allclose(np.array(ecos), want, rtol=0, atol=1e-12)
    assert np.abs(want[:, 3:6]).max() > 0.5  # a reference that moves

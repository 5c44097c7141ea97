"""Missions of 10,000 waypoints in the FMI 2.0 and FMI 3.0 scenario FMUs (the knot file of waypoints_file), run by
FMPy as any FMI tool would: the C's reference equals its numpy twin (waypoints.MinimumJerk.evaluate) at every tick, and
10,001 knots are refused at initialization naming the limit. Until this, 64 waypoints were all the FMU held."""

from __future__ import annotations

import math

import numpy as np
import pytest
from fmpy import simulate_fmu
from support import T
from tiltload.scenario_fmu import knot_file as knots
from tiltload.scenario_fmu import twin, waypoints

REF_NAMES = ["x_ref", "y_ref", "z_ref", "vx_ref", "vy_ref", "vz_ref", "ax_ref", "ay_ref", "az_ref", "psi_ref", "psi_dot_ref"]
N = 10_000


def _mission(n: int) -> list[dict]:
    """A survey over n waypoints 50 ms apart: a wandering path with yaw, some velocities given."""
    rows = []
    for i in range(n):
        t = 0.05 * i
        row = {"t": t, "x": 3 * math.sin(t / 20), "y": 2 * math.sin(t / 7), "z": 1 + 0.3 * math.cos(t / 11), "psi": 0.2 * math.sin(t / 30)}
        if i % 97 == 5:
            row["vx"] = 0.15 * math.cos(t / 20)
        rows.append(row)
    return rows


@pytest.fixture(scope="module")
def knot_file(tmp_path_factory):
    rows = _mission(N)
    waypoints.check(rows, [f"row {i}" for i in range(N)], "mission")
    ref = waypoints.minimum_jerk(rows)
    path = tmp_path_factory.mktemp("mission") / "knots.csv"
    path.write_text(knots.knot_text(ref.knots()))
    return path


@pytest.mark.parametrize("version", [2, 3])
def test_a_10000_waypoint_mission_in_the_fmu_is_its_python_twin(pipeline_fmus, fmi3_fmus, knot_file, version):
    fmu = (pipeline_fmus if version == 2 else fmi3_fmus)["TiltloadScenario"]
    parameters = {"trajectory": 4, "waypoints_file": str(knot_file), "gusts": False}
    stop = 0.05 * (N - 1) + 0.5
    result = simulate_fmu(str(fmu), stop_time=stop, output_interval=T, start_values=parameters, output=REF_NAMES)
    got = np.array([result[name] for name in REF_NAMES]).T
    times = result["time"]
    # doStep(t, h) samples at t and holds: the row at t_{k+1} is the sample at t_k, the first row the value at 0
    sampled = np.r_[times[:1], times[:-1]]
    expected = twin.evaluate(parameters, sampled)
    np.testing.assert_array_equal(got, np.c_[expected.p, expected.v, expected.a, expected.psi, expected.psi_dot])
    assert got.shape[0] > 40_000 and np.abs(got[:, 0]).max() > 2.9  # the whole mission was flown, not held at a point


@pytest.mark.parametrize("version", [2, 3])
def test_one_knot_beyond_the_limit_is_refused_naming_it(pipeline_fmus, fmi3_fmus, knot_file, tmp_path, version):
    fmu = (pipeline_fmus if version == 2 else fmi3_fmus)["TiltloadScenario"]
    lines = knot_file.read_text().splitlines()
    last = [float(x) for x in lines[-1].split(",")]
    last[0] += 0.05
    path = tmp_path / "too_many.csv"
    path.write_text("\n".join([*lines, ",".join(f"{x:.17g}" for x in last)]) + "\n")
    log = []
    with pytest.raises(Exception):  # noqa: B017 (FMPy raises its own exception types per version)
        simulate_fmu(str(fmu), stop_time=0.1, start_values={"trajectory": 4, "waypoints_file": str(path)},
                     logger=lambda *args: log.append(args[-1].decode() if isinstance(args[-1], bytes) else str(args[-1])),
                     debug_logging=True)
    assert any(f"more than {N} knots" in line for line in log), log[-3:]

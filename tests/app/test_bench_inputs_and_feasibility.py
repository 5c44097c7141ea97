"""The open test bench from the command line and in campaigns: trajectory and wind files refused with one line each,
references the vehicle cannot fly refused before the first step, the thesis's trajectories passed."""

from __future__ import annotations

import re
from dataclasses import asdict
from pathlib import Path

import pytest
from support import ROOT
from tiltload.master.app.campaign import spec as campaign_spec
from tiltload.master.app.campaign.run_case import run_case
from tiltload.master.app.cli import main
from tiltload.master.app.feasibility import trajectory_check, yaw_margin
from tiltload.master.app.loop.inputs import READER
from tiltload.scenario_fmu import choice

EXAMPLES = ROOT / "docs" / "examples"
RUN = ["run", "--stop-time", "0.1", "--quiet", "--no-plots", "--no-log"]
GOOD = "t,x,y,z\n0,0,0,1\n5,1,0,1\n"

BAD_FILES = [  # (file name, content, what the line must say)
    ("backwards.csv", "t,x,y,z\n0,0,0,1\n5,1,0,1\n3,2,0,1\n", "line 4: t = 3 s is not after the previous waypoint's t = 5 s"),
    ("same_time.csv", "t,x,y,z\n0,0,0,1\n0,1,0,1\n", "line 3: t = 0 s is not after"),
    ("nan.csv", "t,x,y,z\n0,0,0,1\n5,nan,0,1\n", "line 3: x is nan, not a finite number"),
    ("inf.yaml", "waypoints:\n  - {t: 0, x: 0, y: 0, z: 1}\n  - {t: 5, x: .inf, y: 0, z: 1}\n",
     "waypoints.1.x: inf is not a finite number"),
    ("nan.json", '{"waypoints": [{"t": 0, "x": 0, "y": 0, "z": 1}, {"t": 5, "x": NaN, "y": 0, "z": 1}]}',
     "waypoints.1.x: NaN is not a finite number"),
    ("one.csv", "t,x,y,z\n0,0,0,1\n", "a trajectory needs at least 2 waypoints, got 1"),
    ("one.yaml", "waypoints:\n  - {t: 0, x: 0, y: 0, z: 1}\n", "a trajectory needs at least 2 waypoints, got 1"),
    ("columns.csv", "t,x,y,q\n0,0,0,1\n5,1,0,1\n", "unknown column 'q'"),
    ("missing.csv", "t,x,y\n0,0,0\n5,1,0\n", "missing column z"),
    ("no_header.csv", "0,0,0,1\n5,1,0,1\n", "unknown column '0'"),
    ("twice.csv", "t,x,y,z,x\n0,0,0,1,0\n5,1,0,1,0\n", "column x appears twice"),
    ("short_row.csv", "t,x,y,z\n0,0,0,1\n5,1,0\n", "line 3: 3 values for the header's 4 columns"),
    ("word.csv", "t,x,y,z\n0,0,0,1\n5,one,0,1\n", "line 3: x = 'one' is not a number"),
    ("empty_x.csv", "t,x,y,z\n0,0,0,1\n5,,0,1\n", "line 3: x is empty"),
    ("empty.csv", "", "empty: the first line must be a header"),
    ("negative.csv", "t,x,y,z\n-1,0,0,1\n5,1,0,1\n", "t = -1 s is before the run starts"),
    ("psi_some.csv", "t,x,y,z,psi\n0,0,0,1,0\n5,1,0,1,\n", "psi is given at some waypoints but not all"),
    ("many.csv", "t,x,y,z\n" + "".join(f"{k * 0.5},0,0,1\n" for k in range(10_001)),
     "at most 10000 waypoints fit the scenario FMU, got 10001"),
    ("extra_key.yaml", "waypoints:\n  - {t: 0, x: 0, y: 0, z: 1, speed: 2}\n  - {t: 5, x: 1, y: 0, z: 1}\n",
     "waypoints.0: unknown field speed"),
    ("no_z.yaml", "waypoints:\n  - {t: 0, x: 0, y: 0}\n  - {t: 5, x: 1, y: 0, z: 1}\n", "waypoints.0: 'z' is a required property"),
    ("text_x.json", '{"waypoints": [{"t": 0, "x": "a", "y": 0, "z": 1}, {"t": 1, "x": 0, "y": 0, "z": 1}]}',
     "waypoints.0: x: 'a' is not of type 'number'"),
    ("list.yaml", "- [0, 0, 0, 1]\n- [5, 1, 0, 1]\n", "a trajectory file is a mapping with `waypoints: [...]`"),
    ("broken.json", '{"waypoints": [', "not valid JSON"),
    ("broken.yaml", "waypoints: [\n", "not valid YAML"),
    ("shape_key.yaml", "shape: lissajous\nsize: [1, 1, 1]\nwobble: 3\n", "(top level): Additional properties are not allowed"),
    ("shape_period.yaml", "shape: lemniscate\nperiod: 0\n", "period must be positive, got 0"),
    ("shape_kind.yaml", "shape: spiral\n", "shape: 'spiral' is not one of"),
    ("notes.txt", GOOD, "a scenario file is .csv, .json, .yaml or .yml"),
]
BAD_WIND = [
    ("severity.yaml", "dryden: {severity: extreme}\n", "dryden.severity: 'extreme' is not one of"),
    ("altitude.yaml", "dryden: {severity: light, altitude: 1000}\n", "dryden.altitude: 1000 is greater than the maximum"),
    ("profile.csv", "t,x,y,z\n0,0,0,0\n2,1,0,0\n1,0,0,0\n", "line 4: t = 1 s is not after the previous row's t = 2 s"),
    ("profile_nan.csv", "t,x,y,z\n0,0,0,0\n2,nan,0,0\n", "line 3: x is nan, not a finite number"),
    ("steady.yaml", "steady: [1, 2]\n", "steady: [1, 2] is too short"),
    ("gale.json", '{"steady": [1, 0, 0], "gale": 3}', "Additional properties are not allowed ('gale' was unexpected)"),
]


def _one_line(capsys, argv, fmus, out) -> tuple[int, str]:
    try:
        code = main([*argv, "--fmus", str(fmus), "--out", str(out)])
    except SystemExit as exit_:  # argparse
        code = exit_.code
    _, err = capsys.readouterr()
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in err, err
    return code, lines[0]


@pytest.mark.parametrize("name, content, needle", BAD_FILES, ids=[b[0] for b in BAD_FILES])
def test_a_bad_trajectory_file_is_one_line_and_exit_2(fmus, tmp_path, capsys, name, content, needle):
    path = tmp_path / name
    path.write_text(content)
    code, line = _one_line(capsys, [*RUN, "--trajectory", str(path)], fmus, tmp_path / "runs")
    assert code == 2 and line.startswith("tiltload: error: ") and str(path) in line and needle in line, line


@pytest.mark.parametrize("text, needle", [
    ("no_such.csv", "no_such.csv: no such file"), ("spiral", "neither 0-3, a built-in"), ("7", "the thesis's are 0 (hover), 1, 2 and 3"),
    ("step-x:size=big", "'size=big' must be KEY=NUMBER"), ("step-x:width=1", "step has no parameter 'width'"),
    ("ramp-y:period=-2", "period must be positive, got -2"), ("lissajous:rise=nan", "rise = nan is not a finite number"),
    ("3", "--trajectory 3: the load vehicle has trajectories 0, 1, 2"),
])
def test_a_bad_trajectory_choice_is_one_line(fmus, tmp_path, capsys, text, needle):
    code, line = _one_line(capsys, [*RUN, "--trajectory", text], fmus, tmp_path / "runs")
    assert code == 2 and needle in line, line


@pytest.mark.parametrize("name, content, needle", BAD_WIND, ids=[b[0] for b in BAD_WIND])
def test_a_bad_wind_file_is_one_line_and_exit_2(fmus, tmp_path, capsys, name, content, needle):
    path = tmp_path / name
    path.write_text(content)
    code, line = _one_line(capsys, [*RUN, "--wind", str(path)], fmus, tmp_path / "runs")
    assert code == 2 and str(path) in line and needle in line, line


def test_an_infeasible_path_is_refused_before_the_first_step(fmus, tmp_path, capsys):
    """docs/examples/sprint.csv: 4 m up in 0.95 s from hover, rest to rest; the thrust it needs exceeds Table 5.2's."""
    out = tmp_path / "runs"
    code, line = _one_line(capsys, ["run", "--quiet", "--no-plots", "--trajectory", str(EXAMPLES / "sprint.csv")], fmus, out)
    assert code == 2
    m = re.search(r"the reference is infeasible: f_R would need (\d+\.\d) N at t = (\d+\.\d\d) s; the limit is 30 N", line)
    assert m and 30 < float(m.group(1)) < 40 and 0 < float(m.group(2)) < 0.95, line
    assert "more problems" in line and "--allow-infeasible" in line
    assert not out.exists() or not list(out.glob("*.mcap"))  # nothing ran: no log


def test_allow_infeasible_runs_it_with_warnings(fmus, tmp_path, capsys):
    code = main(["run", "--quiet", "--no-plots", "--no-log", "--trajectory", str(EXAMPLES / "sprint.csv"), "--allow-infeasible",
                 "--stop-time", "0.5", "--fmus", str(fmus), "--scenario", "fsi"])
    out = capsys.readouterr().out
    assert code == 0 and "warning: infeasible: f_R would need" in out


def test_a_yaw_the_design_cannot_hold_is_refused(fmus, tmp_path, capsys):
    """The designs are linearized at psi = 0: at psi = 0.5 rad the DLQR loop's spectral radius exceeds 1."""
    path = tmp_path / "turn.csv"
    path.write_text("t,x,y,z,psi,vpsi\n0,0,0,1,0,\n6,0,0,1,0.5,0\n12,0,0,1,0.5,\n")  # at rest at 0.5 rad from 6 s
    code, line = _one_line(capsys, [*RUN, "--trajectory", str(path), "--controller", "dlqr", "--stop-time", "12"], fmus,
                           tmp_path / "runs")
    m = re.search(r"psi_ref reaches 0\.5 rad at t = (\S+) s; the dlqr design keeps the loop stable for \|psi\| <= (\S+) rad", line)
    assert code == 2 and m and 0.2 < float(m.group(2)) < 0.3, line
    assert yaw_margin.closed_loop_radius("dlqr", "load", 0, 0.5) > 1 > yaw_margin.closed_loop_radius("dlqr", "load", 0, 0.0)


@pytest.mark.parametrize("text, vehicle", [("1", "load"), ("2", "load"), ("3", "uav"), ("lemniscate", "load"),
                                           ("lissajous", "load")])
def test_the_thesis_trajectories_and_the_shapes_pass(text, vehicle):
    trajectory = choice.resolve(text, read=READER)
    kind = "mixed" if vehicle == "load" else "dlqr"
    report = trajectory_check.check_reference(trajectory.parameters, trajectory.duration, vehicle, design=(kind, 0))
    assert report.ok, report.problems
    forces = [float(x) for x in re.findall(r"f_[RL] (-?\d+\.\d+)\.\.(-?\d+\.\d+) N", report.summary)[0]]
    assert 0 < forces[0] <= forces[1] < 30  # the feedforward's thrust range, inside Table 5.2's
    tilt = float(re.search(r"tilt up to (\S+) degrees", report.summary).group(1))
    assert tilt < (8 if text == "2" else 4)  # Table 5.3's corners need the most: about 7 degrees of load pitch


def test_the_trim_check_sees_what_the_feedforward_cannot(tmp_path):
    """A fast sideways dash: the feedforward (3.18) holds the trim's angles, so its thrusts barely change; the trim along
    the path shows the load would have to swing beyond 30 degrees."""
    path = tmp_path / "dash.csv"
    path.write_text("t,x,y,z\n0,0,0,3\n2.5,10,0,3\n5,10,0,3\n")
    trajectory = choice.resolve(str(path), read=READER)
    report = trajectory_check.check_reference(trajectory.fmu_parameters(tmp_path), trajectory.duration)
    assert any(re.match(r"theta would need 3\d\.\d degrees at t = ", p) for p in report.problems), report.problems
    assert not any(p.startswith("f_") for p in report.problems)


def test_a_campaign_flies_a_waypoint_file_and_refuses_the_case_it_cannot(fmus, tmp_path):
    """base.trajectory a file next to the spec; a heavy load (5 kg) needs more thrust than the rotors have: that case's
    row says so, before it runs; the other case flies."""
    (tmp_path / "mission.csv").write_text((EXAMPLES / "mission.csv").read_text())
    (tmp_path / "gusty.yaml").write_text("steady: [1, 0, 0]\ndryden: {severity: light}\n")
    spec = tmp_path / "bench.toml"
    spec.write_text('name = "bench"\n[base]\nscenario = "fsi"\ntrajectory = "mission.csv"\nwind = "gusty.yaml"\n'
                    'controllers = ["dlqr"]\nstop_time = 2.0\n[vary]\n[[vary.parameters]]\nname = "m_L"\n'
                    'targets = ["plant.m_L"]\nvalues = [0.05, 5.0]\n')
    c = campaign_spec.load(spec)
    assert c.trajectory.trajectory.code == 4 and dict(c.trajectory.wind)["dryden"] == 1
    rows = {case.values["m_L"]: run_case(c.base(), asdict(case), str(fmus), None)["row"] for case in c.cases}
    assert rows[0.05]["completed"] and rows[0.05]["error"] == "" and rows[0.05]["ISE(x)"] < 1e-3
    assert not rows[5.0]["completed"]
    assert re.match(r"the reference is infeasible: the trim's f_[RL] would need 3\d\.\d N at t = ", rows[5.0]["error"])


@pytest.mark.parametrize("field, value, needle", [
    ("trajectory", '"nowhere.csv"', "nowhere.csv: no such file"), ("trajectory", "true", "base.trajectory"),
    ("wind", '"calm.yaml"', "calm.yaml: no such file"), ("max_tilt", "0", "base.max_tilt"),
])
def test_a_bad_campaign_trajectory_names_the_field(tmp_path, field, value, needle):
    spec = tmp_path / "bad.toml"
    spec.write_text(f'name = "bad"\n[base]\n{field} = {value}\n[vary]\n')
    with pytest.raises(campaign_spec.SpecError) as err:
        campaign_spec.load(spec)
    assert needle in str(err.value) and str(spec) in str(err.value)


def test_examples_are_valid():
    for name in ("mission.csv", "sprint.csv"):
        assert choice.resolve(str(EXAMPLES / name), read=READER).code == 4
    assert Path(EXAMPLES / "gusty_wind.yaml").is_file()

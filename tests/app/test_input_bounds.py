"""Small files with huge costs, and numbers at the edges (issue 37, classes 3 and 7): each is one line naming the file
and the problem, exit 2, before anything is sized by it. Each case failed on the code before engine/user_files.py:
a 226 MB error line or MemoryError (alias bombs), 621 GiB asked for (a mission ending at 1e9 s), MemoryError (a grid),
"a bug" (400 digits, 1e-300 s, a 140 kB cell), "index 0 is out of bounds" (a wind of 1e300), a hang (a FIFO)."""

from __future__ import annotations

import os
import resource
import subprocess
import sys

import numpy as np
import pytest
from tiltload.master.app.cli import main
from tiltload.scenario_fmu import waypoints

RUN = ["run", "--stop-time", "0.1", "--quiet", "--no-plots", "--no-log"]


def bomb(levels: int = 9, width: int = 10) -> str:
    """A YAML alias bomb: width^levels leaves from levels * width aliases (10^9 for 9 x 10)."""
    lines = [f"a0: &a0 [{', '.join(['1'] * width)}]"]
    lines += [f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * width)}]" for i in range(1, levels)]
    return "\n".join(lines) + "\n"


def _line(capsys, argv, fmus=None, out=None) -> tuple[int, str]:
    extra = [] if fmus is None else ["--fmus", str(fmus), "--out", str(out)]
    try:
        code = main([*argv, *extra])
    except SystemExit as exit_:
        code = exit_.code
    _, err = capsys.readouterr()
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in err, err[:2000]
    return code, lines[0]


def _memory_grew_by() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # MB (Linux: kB)


@pytest.mark.parametrize("surface", ["trajectory", "wind", "faults", "campaign"])
def test_a_yaml_alias_bomb_is_refused_at_its_first_alias(fmus, tmp_path, capsys, surface):
    before = _memory_grew_by()
    name = "spec.yaml" if surface == "campaign" else f"{surface}.yaml"
    path = tmp_path / name
    path.write_text(("name: x\n" if surface == "campaign" else "") + bomb())
    argv = ["campaign", str(path)] if surface == "campaign" else [*RUN, f"--{surface}", str(path)]
    code, line = _line(capsys, argv, fmus, tmp_path / "out")
    assert code == 2 and str(path) in line and "a YAML alias (*a0): aliases are not accepted" in line, line
    assert len(line) < 300 and _memory_grew_by() - before < 200  # the 10^9 leaves were never built


def test_a_mission_ending_at_1e9_s_is_refused_with_the_bound(fmus, tmp_path, capsys):
    path = tmp_path / "far.csv"
    path.write_text("t,x,y,z\n0,0,0,1\n1e9,1,0,1\n")
    code, line = _line(capsys, [*RUN, "--trajectory", str(path)], fmus, tmp_path)
    assert code == 2 and line.endswith(f"{path}: line 3: t = 1e+09 is outside 0 to 10800 s (a mission ends within 3 h)"), line


def test_waypoints_1e_300_s_apart_are_refused(fmus, tmp_path, capsys):
    path = tmp_path / "close.csv"
    path.write_text("t,x,y,z\n0,0,0,1\n1e-300,1,0,1\n")
    code, line = _line(capsys, [*RUN, "--trajectory", str(path)], fmus, tmp_path)
    assert code == 2 and "line 3: t = 1e-300 s is 1e-300 s after the previous waypoint; waypoints are at " \
                          "least 0.001 s apart" in line, line


@pytest.mark.parametrize("surface, text", [
    ("trajectory", '{"waypoints": [{"t": 0, "x": 0, "y": 0, "z": 1}, {"t": 5, "x": %s, "y": 0, "z": 1}]}'),
    ("wind", '{"steady": [%s, 0, 0]}'),
])
def test_a_400_digit_integer_in_json_is_refused_where_it_stands(fmus, tmp_path, capsys, surface, text):
    path = tmp_path / f"{surface}.json"
    path.write_text(text % ("1" * 400))
    code, line = _line(capsys, [*RUN, f"--{surface}", str(path)], fmus, tmp_path)
    where = "waypoints.1.x" if surface == "trajectory" else "steady.0"
    assert code == 2 and line.endswith(f"{path}: {where}: an integer of 400 digits (at most 18)"), line


def test_a_csv_cell_of_140_kB_is_refused_by_its_line_length(fmus, tmp_path, capsys):
    path = tmp_path / "wide.csv"
    path.write_text("t,x,y,z\n0,0,0,1\n5," + "1" * 140_000 + ",0,1\n")
    code, line = _line(capsys, [*RUN, "--trajectory", str(path)], fmus, tmp_path)
    assert code == 2 and line.endswith(f"{path}: line 3: 140006 characters, more than 4096"), line


@pytest.mark.parametrize("name, text, needle", [
    ("wind.json", '{"steady": [1e300, 0, 0]}', "steady.0: 1e+300 is greater than the maximum of 100.0"),
    ("wind.yaml", "steady: [0, -1.0e+300, 0]\n", "steady.1: -1e+300 is less than the minimum of -100.0"),
    ("wind.csv", "t,x,y,z\n0,1e300,0,0\n", "line 2: x = 1e+300 is outside -100 to 100 m/s"),
])
def test_a_wind_of_1e300_is_refused_when_read_with_its_range(fmus, tmp_path, capsys, name, text, needle):
    path = tmp_path / name
    path.write_text(text)
    code, line = _line(capsys, [*RUN, "--wind", str(path)], fmus, tmp_path)
    assert code == 2 and line.endswith(f"{path}: {needle}"), line


def test_a_campaign_grid_is_counted_before_it_is_built(tmp_path, capsys):
    path = tmp_path / "grid.toml"
    values = ", ".join(str(0.1 + 0.01 * k) for k in range(20))
    params = "".join(f'[[vary.parameters]]\nname = "p{i}"\ntargets = ["plant.m_L"]\nvalues = [{values}]\n' for i in range(8))
    path.write_text(f'name = "g"\n[base]\nscenario = "zse"\n[vary]\nseeds = [1, 2]\n{params}')
    code, line = _line(capsys, ["campaign", str(path)])
    assert code == 2 and line.endswith(f"{path}: vary: the grid makes 51200000000 runs (20 x 20 x 20 x 20 x 20 x 20 x 20 x 20 "
                                       "points, 2 runs each: controllers x seeds); a campaign has at most 100000"), line


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs")
@pytest.mark.parametrize("flag", ["--trajectory", "--wind", "--faults"])
@pytest.mark.slow
def test_a_fifo_given_as_a_file_is_refused_without_opening_it(fmus, tmp_path, flag):
    fifo = tmp_path / ("mission.csv" if flag == "--trajectory" else "f.json")
    os.mkfifo(fifo)
    done = subprocess.run([sys.executable, "-m", "tiltload.master.app.cli", *RUN, flag, str(fifo), "--fmus", str(fmus)],
                          capture_output=True, text=True, timeout=120, env={**os.environ})
    lines = [ln for ln in done.stderr.splitlines() if ln.strip()]
    assert done.returncode == 2 and len(lines) == 1 and lines[0].endswith(f"{fifo}: a FIFO, not a regular file"), done.stderr


def test_the_banded_minimum_jerk_is_the_dense_solve():
    """The banded solve against the quadratic program written densely (the 3n x 3n cost matrix, the free entries solved
    by numpy), on a mission with fixed and free interior velocities and accelerations and uneven spacing."""
    rng = np.random.default_rng(7)
    n = 60
    t = np.cumsum(rng.uniform(0.01, 4.0, n))
    t -= t[0]
    p = rng.normal(size=n)
    v = [0.0, *[rng.normal() if rng.random() < 0.2 else None for _ in range(n - 2)], 0.0]
    a = [0.0, *[rng.normal() if rng.random() < 0.2 else None for _ in range(n - 2)], 0.0]
    G = np.zeros((3 * n, 3 * n))
    for i in range(n - 1):
        T = t[i + 1] - t[i]
        S = np.diag([1, T, T * T, 1, T, T * T])
        G[3 * i:3 * i + 6, 3 * i:3 * i + 6] += S @ waypoints.H_JERK @ S / T**5
    w = np.full(3 * n, np.nan)
    w[0::3] = p
    w[1::3] = [np.nan if x is None else x for x in v]
    w[2::3] = [np.nan if x is None else x for x in a]
    free = np.isnan(w)
    w[free] = np.linalg.solve(G[np.ix_(free, free)], -G[np.ix_(free, ~free)] @ w[~free])
    vel, acc = (x[:, 0] for x in waypoints._solve_axes(t, p[:, None], [v], [a]))
    np.testing.assert_allclose(vel, w[1::3], rtol=1e-7, atol=1e-9 * np.abs(w[1::3]).max())
    np.testing.assert_allclose(acc, w[2::3], rtol=1e-7, atol=1e-9 * np.abs(w[2::3]).max())

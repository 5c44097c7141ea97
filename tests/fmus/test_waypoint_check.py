"""The waypoints' check asks JSON Schema only when a row is not plain (an unknown field, a missing one, a value that is
not a number): on random rows, its verdict is the one of the schema itself (jsonschema) plus its own order rules.
A knot file read once is read again when it changes, and its reference's knots are the file's numbers."""

from __future__ import annotations

import jsonschema
import numpy as np
import pytest
from tiltload.scenario_fmu import knot_file
from tiltload.scenario_fmu import waypoints as W
from tiltload.scenario_fmu.files import ScenarioFileError


def _by_the_schema(rows: list[dict]) -> bool:
    """Whether the rows meet the schema and the order rules, judged without check()."""
    if jsonschema.Draft202012Validator({"type": "array", "items": W.SCHEMA}).is_valid(rows) is False:
        return False
    if len({("psi" in r) for r in rows}) > 1 or any(("vpsi" in r or "apsi" in r) and "psi" not in r for r in rows):
        return False
    return all(rows[k]["t"] - rows[k - 1]["t"] >= W.MIN_GAP for k in range(1, len(rows)))


def _random_rows(rng) -> list[dict]:
    rows, t = [], 0.0
    for _ in range(int(rng.integers(2, 5))):
        t += float(rng.choice([1.0, 2.5, -1.0, 1e-4]))
        row = {"t": t, "x": float(rng.normal()), "y": float(rng.normal()), "z": float(rng.normal())}
        for field in rng.choice(["vx", "psi", "az", "vpsi"], size=int(rng.integers(0, 3)), replace=False):
            row[str(field)] = float(rng.normal(scale=10))
        kind = rng.integers(0, 12)
        if kind == 0:
            row["bogus"] = 1.0  # an unknown field
        elif kind == 1:
            del row["y"]  # a required one missing
        elif kind == 2:
            row["x"] = "1.0"  # a string
        elif kind == 3:
            row["z"] = True  # a bool is no number
        elif kind == 4:
            row["x"] = 2e5  # out of range
        elif kind == 5:
            row["vx"] = 7  # an int is a number
        rows.append(row)
    return rows


@pytest.mark.parametrize("seed", range(4))
def test_the_check_agrees_with_the_schema_on_random_rows(seed):
    rng = np.random.default_rng(seed)
    verdicts = set()
    for _ in range(250):
        rows = _random_rows(rng)
        try:
            W.check(rows, [f"row {i}" for i in range(len(rows))], "random")
            accepted = True
        except ScenarioFileError:
            accepted = False
        assert accepted == _by_the_schema(rows), rows
        verdicts.add(accepted)
    assert verdicts == {True, False}  # both kinds met


def test_a_knot_file_is_read_again_when_it_changes(tmp_path):
    import os

    first = W.minimum_jerk([{"t": 0.0, "x": 0.0, "y": 0.0, "z": 1.0}, {"t": 4.0, "x": 1.0, "y": 0.0, "z": 1.0}])
    second = W.minimum_jerk([{"t": 0.0, "x": 0.0, "y": 0.0, "z": 1.0}, {"t": 5.0, "x": 2.0, "y": 1.0, "z": 1.5}])
    path = tmp_path / "mission.csv"
    path.write_text(knot_file.knot_text(first.knots()))
    read = knot_file.read_knots(path)
    assert np.array_equal(read.knots(), first.knots()) and knot_file.read_knots(path) is read  # unchanged: read once
    with pytest.raises(ValueError):
        read.p[0, 0] = 9.0  # shared by later reads: read-only
    stamp = path.stat().st_mtime_ns
    path.write_text(knot_file.knot_text(second.knots()))  # the same path, other knots (kept at the same time stamp too)
    os.utime(path, ns=(stamp, stamp))
    assert np.array_equal(knot_file.read_knots(path).knots(), second.knots())
    path.write_text("t,x\n")
    with pytest.raises(ScenarioFileError, match="header"):
        knot_file.read_knots(path)


def test_a_mission_file_written_for_the_fmu_is_read_as_its_text_reads(tmp_path):
    """The knot file a moved mission writes is not parsed again by the feasibility check (choice.Trajectory
    .fmu_parameters hands its knots to read_knots): what read_knots then gives is, bit for bit, what parsing the file's
    text gives; a file changed since is read again, and a table the file check refuses is refused the same way."""
    import os

    from tiltload.scenario_fmu.choice import Trajectory

    rng = np.random.default_rng(4)
    rows = [{"t": float(t), "x": float(x), "y": float(y), "z": float(z)}
            for t, x, y, z in zip(np.cumsum(rng.uniform(0.5, 3.0, 6)), *rng.normal(size=(3, 6)))]
    ref = W.minimum_jerk(rows)
    trajectory = Trajectory("m", 4, (), ref.start, ref.duration, "", tuple(map(tuple, ref.knots().tolist())))
    path = trajectory.fmu_parameters(tmp_path)["waypoints_file"]
    given = knot_file.read_knots(path)
    copy = tmp_path / "copy.csv"
    copy.write_bytes(open(path, "rb").read())
    parsed = knot_file.read_knots(copy)  # another path: parsed from its text
    assert given is not parsed
    for a, b in zip((given.t, given.p, given.v, given.a), (parsed.t, parsed.p, parsed.v, parsed.a)):
        assert np.array_equal(a.view(np.int64), b.view(np.int64))  # the same doubles, the sign of zero too
    assert trajectory.fmu_parameters(tmp_path)["waypoints_file"] == path and knot_file.read_knots(path) is given  # kept
    deeper = trajectory.fmu_parameters(tmp_path / "new" / "folder")["waypoints_file"]  # the folder made for it
    assert open(deeper, "rb").read() == open(path, "rb").read()
    piped = tmp_path / "piped"
    piped.mkdir()
    os.mkfifo(piped / os.path.basename(path))  # a pipe where the file goes: replaced, never opened (it would block)
    assert open(trajectory.fmu_parameters(piped)["waypoints_file"], "rb").read() == open(path, "rb").read()
    other = W.minimum_jerk([{"t": 0.0, "x": 0.0, "y": 0.0, "z": 1.0}, {"t": 3.0, "x": 1.0, "y": 2.0, "z": 1.0}])
    stamp = os.stat(path).st_mtime_ns
    with open(path, "w") as f:
        f.write(knot_file.knot_text(other.knots()))
    os.utime(path, ns=(stamp, stamp))
    assert np.array_equal(knot_file.read_knots(path).knots(), other.knots())  # changed: read again
    assert trajectory.fmu_parameters(tmp_path)["waypoints_file"] == path  # and written again by the mission it names
    assert open(path).read() == knot_file.knot_text(ref.knots()) and np.array_equal(knot_file.read_knots(path).knots(), ref.knots())
    backwards = ref.knots()[::-1].copy()  # a table read_knots refuses: not remembered, the file's reader refuses it
    fresh = tmp_path / "fresh.csv"
    fresh.write_text(knot_file.knot_text(backwards))
    knot_file.known_knots(fresh, os.stat(fresh), backwards)
    with pytest.raises(ScenarioFileError, match="times that do not increase"):
        knot_file.read_knots(fresh)

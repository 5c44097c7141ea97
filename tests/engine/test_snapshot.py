"""Snapshots: a run continued from one equals the uninterrupted run bit for bit (metrics and log), faults, delay lines
and isolated FMUs included; bad snapshots are one line each."""

from __future__ import annotations

import json
import zipfile
from pathlib import Path

import pytest
from mcap.reader import make_reader
from support.fmi2_session import foreign_copy
from tiltload.master.app.cli import main
from tiltload.master.app.loop.fmus import is_foreign
from tiltload.master.app.loop.scene import scene_channels
from tiltload.master.app.loop.thesis import default_system, loop_metrics
from tiltload.master.engine import snapshot
from tiltload.master.engine.faults.parse import parse
from tiltload.master.engine.run import run_system

STOP, AT = 6.0, 3.0
# active across the snapshot: the manipulator's held samples and flags must survive it
DROPOUT = [{"name": "GPS lost", "action": "dropout", "targets": ["sensors.meas_x_B", "sensors.meas_y_B"],
            "flag": "sensors.gps_new", "start": 2.0, "end": 4.5},
           {"action": "bias", "target": "plant.f_R", "value": -0.5, "start": 2.5},
           # in the C loop: the histories they read (its rings) must survive it too
           {"action": "delay", "target": "sensors.meas_d_BL_y", "value": 7, "start": 2.9, "end": 3.5},
           {"action": "jitter", "target": "sensors.meas_d_BL_x", "value": 5, "start": 1.0, "end": 5.0, "seed": 3}]


def messages(path: Path) -> dict[str, list]:
    out: dict[str, list] = {}
    with open(path, "rb") as f:
        for _, channel, m in make_reader(f).iter_messages():
            out.setdefault(channel.topic, []).append((m.log_time, m.data))
    return out


def loop(fmus, case: str, tmp_path: Path):
    if case == "faults":
        system = default_system(fmus, "zse", 1, "mixed")
        system.faults = parse(DROPOUT)
    elif case == "delay":
        system = default_system(fmus, "lkf", 1, "dlqr", delay=True)
    else:  # the controller foreign: it runs in a worker process, its state travels through the pipe
        system = default_system(fmus, "fsi", 1, "mixed")
        system.instance("controller").fmu = foreign_copy(fmus / "TiltloadController.fmu", tmp_path / "Foreign.fmu")
    return system


@pytest.mark.parametrize("case", ["faults", "delay", "isolated"])
@pytest.mark.slow
def test_a_continued_run_equals_the_uninterrupted_one_bit_for_bit(fmus, tmp_path, case):
    kw = dict(progress=False, channels=scene_channels("plant"), isolate=is_foreign)
    full = run_system(loop(fmus, case, tmp_path), STOP, tmp_path / "full.mcap", loop_metrics(), **kw)
    taken = []
    run_system(loop(fmus, case, tmp_path), STOP, None, loop_metrics(), checkpoints=[(AT, lambda ex: taken.append(
        snapshot.write(snapshot.take(ex), tmp_path / "at.snapshot")))], **kw)
    snap = snapshot.read(taken[0])
    assert snap.time == pytest.approx(AT) and snap.ticks_done == 250
    cont = run_system(loop(fmus, case, tmp_path), STOP, tmp_path / "cont.mcap", loop_metrics(), resume=snap, **kw)
    assert full.error is None and cont.error is None
    assert cont.metrics == full.metrics  # the integrals carried over, every tick after the snapshot the same
    a, b = messages(tmp_path / "full.mcap"), messages(tmp_path / "cont.mcap")
    assert set(b) <= set(a)
    for topic, continued in b.items():
        assert continued == a[topic][-len(continued):], topic  # the uninterrupted log's tail, log times included
    assert len(b["/plant"]) == 250 and len(b["/scene"]) == 63  # ticks 250..499; the scene keeps its every-4th cadence


def test_the_command_line_branches_a_run_at_a_snapshot(fmus, tmp_path, capsys):
    common = ["--fmus", str(fmus), "--out", str(tmp_path), "--quiet", "--no-plots", "--scenario", "fsi", "--controller", "dlqr"]
    assert main(["run", "--stop-time", "4", "--snapshot-at", "2", str(tmp_path / "s.snapshot"), "--name", "whole", *common]) == 0
    out = capsys.readouterr().out
    assert "snapshot at t = 2.004 s" in out  # the nearest tick
    common = common[:6]  # a continued run takes its loop from the snapshot
    assert main(["run", "--from-snapshot", str(tmp_path / "s.snapshot"), "--name", "rest", *common]) == 0
    assert "continuing from" in capsys.readouterr().out
    a, b = messages(tmp_path / "whole.mcap"), messages(tmp_path / "rest.mcap")
    # 4 s is 333.33 ticks: the run ends at the first tick after it (334, 4.008 s), 167 steps after the snapshot's tick 167
    assert b["/plant"] == a["/plant"][-len(b["/plant"]):] and len(b["/plant"]) == 167
    # a branch: another fault from the snapshot on, another stop time
    faults = tmp_path / "f.json"
    faults.write_text(json.dumps([{"action": "scale", "target": "plant.f_L", "value": 0.7, "start": 2.5}]))
    assert main(["run", "--from-snapshot", str(tmp_path / "s.snapshot"), "--faults", str(faults), "--stop-time", "3",
                 "--name", "branch", *common]) == 0
    c = messages(tmp_path / "branch.mcap")
    assert c["/plant"][:41] == b["/plant"][:41] and c["/plant"][42] != b["/plant"][42]  # same until the fault bites


def _damaged(src: Path, dest: Path, edit) -> Path:
    with zipfile.ZipFile(src) as z, zipfile.ZipFile(dest, "w") as out:
        for item in z.infolist():
            data = z.read(item.filename)
            if item.filename == "manifest.json":
                data = json.dumps(edit(json.loads(data))).encode()
            out.writestr(item, data)
    return dest


def test_bad_snapshots_are_one_line_each(fmus, tmp_path, capsys):
    common = ["--fmus", str(fmus), "--out", str(tmp_path), "--quiet", "--no-plots"]
    good = tmp_path / "good.snapshot"
    assert main(["run", "--scenario", "fsi", "--stop-time", "1", "--snapshot-at", "0.5", str(good), *common]) == 0
    capsys.readouterr()
    raw = good.read_bytes()
    (tmp_path / "truncated.snapshot").write_bytes(raw[: len(raw) // 2])
    (tmp_path / "text.snapshot").write_text("not a snapshot")
    flipped = bytearray(raw)
    flipped[len(raw) // 3] ^= 0xFF
    (tmp_path / "flipped.snapshot").write_bytes(bytes(flipped))

    def other_build(m):
        m["fingerprint"]["instances"][3]["guid"] = "{00000000-0000-0000-0000-000000000000}"
        return m

    def other_system(m):
        m["fingerprint"]["instances"][1]["name"] = "cameras"
        return m
    cases = {"missing.snapshot": "no such file", "truncated.snapshot": "truncated", "text.snapshot": "not a snapshot",
             "flipped.snapshot": "", "build.snapshot": "plant: the snapshot was taken with another build of its FMU",
             "system.snapshot": "the snapshot is of another system",
             "format.snapshot": "is not a tiltload snapshot (format 'x'"}
    _damaged(good, tmp_path / "build.snapshot", other_build)
    _damaged(good, tmp_path / "system.snapshot", other_system)
    _damaged(good, tmp_path / "format.snapshot", lambda m: {**m, "format": "x"})
    for name, needle in cases.items():
        code = main(["run", "--from-snapshot", str(tmp_path / name), *common])
        err = capsys.readouterr().err.strip().splitlines()
        assert code == 2 and len(err) == 1 and needle in err[0] and "Traceback" not in err[0], (name, err)
    for argv, needle in ((["--scenario", "lkf"], "--scenario cannot change in a continued run"),
                         (["--set", "plant.m_L=0.2"], "plant.m_L is a fixed parameter"),
                         (["--set", "sensors.seed=nan"], "sensors.seed: nan is not a finite number"),  # the parser's
                         (["--set", "sensors.seed=1.5"], "sensors.seed = 1.5: must be a whole number")):
        try:
            code = main(["run", "--from-snapshot", str(good), *argv, *common])
        except SystemExit as refused:  # a value no FMU parameter can hold is refused by the option's own type
            code = refused.code
        err = capsys.readouterr().err.strip().splitlines()
        assert code == 2 and len(err) == 1 and needle in err[0], err


def test_an_fmu_that_cannot_serialize_its_state_is_refused_by_name(fmus, tmp_path, capsys):
    """A pythonfmu controller (tiltload wrap) declares canSerializeFMUstate false."""
    example = Path(__file__).resolve().parents[2] / "docs" / "examples" / "hover_lqr.py"
    fmu = tmp_path / "hover.fmu"
    assert main(["wrap", str(example), "--out", str(fmu)]) == 0
    code = main(["run", "--controller", str(fmu), "--scenario", "fsi", "--stop-time", "1", "--snapshot-at", "0.5",
                 str(tmp_path / "x.snapshot"), "--fmus", str(fmus), "--out", str(tmp_path), "--quiet", "--no-plots"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1 and len(err) == 1 and "controller: its FMU cannot serialize its state" in err[0], err


def test_a_file_s_digest_is_its_content_s_and_follows_a_replaced_or_rewritten_file(tmp_path):
    import hashlib
    import os

    from tiltload.master.engine.snapshot import file_digest

    path = tmp_path / "a.fmu"
    path.write_bytes(b"one")
    assert file_digest(path) == hashlib.sha256(b"one").hexdigest()
    assert file_digest(path) == hashlib.sha256(b"one").hexdigest()  # the second time from the memo: the same
    (tmp_path / "b").write_bytes(b"two")
    os.replace(tmp_path / "b", path)  # a rebuild replaces the file: another inode
    assert file_digest(path) == hashlib.sha256(b"two").hexdigest()
    path.write_bytes(b"three!")  # rewritten in place: another size and modification time
    assert file_digest(path) == hashlib.sha256(b"three!").hexdigest()

"""MCAP logs: every logged value is what the FMU output, NaN survives, old logs read, --no-log and --log-every."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from mcap.reader import make_reader
from support import ROOT
from tiltload.master.app.cli import main
from tiltload.master.app.loop.scene import scene_channels
from tiltload.master.app.loop.thesis import default_system
from tiltload.master.app.views.plot import plot_run
from tiltload.master.engine.execution import Execution
from tiltload.master.engine.log import reader as log_reader
from tiltload.master.engine.log.encoding import FixedMessage
from tiltload.master.engine.log.logger import McapLogger

OLD_LOG = ROOT / "tests" / "support" / "data" / "json_log_v0.mcap"  # written by tiltload before the protobuf log (JSON channels)


def protobuf_messages(path: Path, topic: str) -> list:
    """Decode a channel with Google's protobuf library from the schema in the file: independent of our decoder."""
    with open(path, "rb") as f:
        out, cls = [], None
        for schema, channel, message in make_reader(f).iter_messages(topics=[topic]):
            if cls is None:
                assert channel.message_encoding == "protobuf" and schema.encoding == "protobuf"
                pool = descriptor_pool.DescriptorPool()
                for file in descriptor_pb2.FileDescriptorSet.FromString(schema.data).file:
                    pool.Add(file)
                cls = message_factory.GetMessageClass(pool.FindMessageTypeByName(schema.name))
            out.append(cls.FromString(message.data))
    return out


def test_every_logged_value_is_what_the_fmu_output(fmus, tmp_path):
    """ZSE loop, 1.2 s: the last message of each instance, decoded by protobuf, equals the instance's outputs; every
    channel has one message a tick from 0 to 1.2 s (docs/master.md, "Signals at a run's edges")."""
    log = tmp_path / "run.mcap"
    ex = Execution(default_system(fmus, "zse", 1, "mixed"), [McapLogger(log, derived=scene_channels("plant"))])
    ex.instantiate()
    ex.end(1.2)
    final = {name: {v.name: inst.values[t][i] for t in ("Real", "Integer", "Boolean") for i, v in enumerate(inst.outputs[t])}
             for name, inst in ex.instances.items()}
    ex.close()
    ours = log_reader.read(log)
    for name, values in final.items():
        pb = protobuf_messages(log, f"/{name}")
        assert len(pb) == len(ours[f"/{name}"]) == 101  # 0, 0.012, ..., 1.2
        assert [m["t"] for m in ours[f"/{name}"]] == pytest.approx([k * 0.012 for k in range(101)], abs=1e-12), name
        for key, value in values.items():
            assert getattr(pb[-1], key) == value == ours[f"/{name}"][-1][key], (name, key)
    assert math.isclose(ours["/plant"][-1]["t"], 1.2) and ours["/controller"][-1]["t"] == pytest.approx(1.2)
    assert len(ours["/scene"]) == 26  # every 4th plant step: 21 Hz


def test_non_finite_values_survive_the_encoding():
    enc = FixedMessage("x", ["a", "b", "c"], ["k"], ["f"])
    data = enc.encode(0.5, np.array([np.nan, np.inf, -1.25]), np.array([-7]), np.array([1]))
    back = enc.decode(data)
    assert math.isnan(back["a"]) and back["b"] == math.inf and back["c"] == -1.25 and back["k"] == -7 and back["f"] is True


def test_a_log_from_before_the_protobuf_log_still_reads_and_plots(tmp_path):
    data = log_reader.read(OLD_LOG)
    assert {k: len(v) for k, v in data.items()} == {"/scenario": 101, "/sensors": 101, "/controller": 101, "/plant": 101,
                                                    "/scene": 26}
    assert data["/plant"][0]["x"] == pytest.approx(1.7)
    files = plot_run(OLD_LOG, tmp_path)
    assert len(files) == 7 and all(f.stat().st_size > 10_000 for f in files)
    assert "metrics" in log_reader.read_metadata(OLD_LOG)


def test_no_log_runs_metrics_only_and_log_every_thins_the_log(fmus, tmp_path, capsys):
    args = ["--scenario", "fsi", "--stop-time", "1.2", "--fmus", str(fmus), "--quiet"]
    assert main(["run", *args, "--no-log", "--out", str(tmp_path / "a")]) == 0
    out = capsys.readouterr().out
    assert "log: none (--no-log)" in out and "ISE(x)" in out and not list((tmp_path / "a").glob("*.mcap"))
    assert main(["run", *args, "--no-plots", "--log-every", "5", "--out", str(tmp_path / "b")]) == 0
    data = log_reader.read(next((tmp_path / "b").glob("*.mcap")))
    assert len(data["/plant"]) == 21 and len(data["/scene"]) == 6  # steps 0, 5, ... 100 of 101; the scene every 20th
    assert [round(m["t"], 9) for m in data["/plant"][:3]] == [0.0, 0.06, 0.12]


@pytest.fixture(scope="module")
def two_second_log(fmus, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("damage")
    assert main(["run", "--stop-time", "2", "--fmus", str(fmus), "--out", str(out), "--quiet", "--no-plots", "--name", "run"]) == 0
    return out / "run.mcap"


CHUNK_DATA = 1 + 8 + 8 + 8 + 8 + 4 + 4 + 4 + 8  # opcode, length, start and end times, size, CRC, "zstd", records length


def _flip_inside_a_chunk(log: Path, dest: Path, offset: int, count: int = 64) -> float:
    """dest: log with count bytes inverted at offset into the middle chunk record (footer intact); that chunk's start."""
    with open(log, "rb") as f:
        chunks = sorted(make_reader(f).get_summary().chunk_indexes, key=lambda c: c.chunk_start_offset)
    middle = chunks[len(chunks) // 2]
    data = bytearray(log.read_bytes())
    at = middle.chunk_start_offset + offset
    data[at:at + count] = bytes(b ^ 0xFF for b in data[at:at + count])
    dest.write_bytes(bytes(data))
    return middle.message_start_time / 1e9


@pytest.mark.parametrize("offset, what", [(CHUNK_DATA + 100, r"chunk \d+, from t = \d\.\d+ s, (fails its CRC check|does not "
                                                                        r"decompress)"),
                                           (CHUNK_DATA - 8, r"unreadable record after chunk \d+")])
@pytest.mark.slow
def test_a_damaged_log_is_reported_by_every_reader(two_second_log, tmp_path, capsys, offset, what):
    """64 flipped bytes mid-file (in a chunk's data, or in its framing), footer intact: read, plot and compare each
    say it is damaged and up to when it holds."""
    bad = tmp_path / "bad.mcap"
    damaged_from = _flip_inside_a_chunk(two_second_log, bad, offset)
    assert 0.3 < damaged_from < 1.7
    with pytest.raises(log_reader.DamagedLog, match=rf"is damaged \({what}.*\): intact up to t = \d\.\d+ s of 2\.0\d\d s"):
        log_reader.read(bad)
    data, state = log_reader.read_checked(bad, topics=["/plant"])
    assert state.damage and not state.torn and state.intact_until <= damaged_from
    assert data["/plant"][-1]["t"] <= damaged_from and data["/plant"][-1]["t"] >= damaged_from - 0.2  # the front is kept
    assert main(["plot", str(bad), "--out", str(tmp_path / "plots")]) == 1  # the intact part drawn, and said
    err_lines = capsys.readouterr().err.strip().splitlines()
    assert len(err_lines) == 1 and "is damaged" in err_lines[0] and "intact up to t = " in err_lines[0], err_lines
    assert len(list((tmp_path / "plots").glob("*.png"))) == 7
    for args in ([str(bad), str(two_second_log)], [str(two_second_log), str(bad)]):
        assert main(["compare", *args]) == 2
        err_lines = capsys.readouterr().err.strip().splitlines()
        assert len(err_lines) == 1 and "is damaged" in err_lines[0], err_lines
    assert log_reader.check(two_second_log).complete  # the original is fine

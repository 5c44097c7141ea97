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
from tiltload.master.app.loop import default_system
from tiltload.master.app.plot import plot_run
from tiltload.master.app.scene import scene_channels
from tiltload.master.engine import log_reader
from tiltload.master.engine.execution import Execution
from tiltload.master.engine.log_encoding import FixedMessage
from tiltload.master.engine.mcap_log import McapLogger

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
    """ZSE loop, 1.2 s: the last message of each instance, decoded by protobuf, equals the instance's outputs."""
    log = tmp_path / "run.mcap"
    ex = Execution(default_system(fmus, "zse", 1, "mixed"), [McapLogger(log, derived=scene_channels("plant"))])
    ex.instantiate()
    ex.run(1.2)
    final = {name: {v.name: inst.values[t][i] for t in ("Real", "Integer", "Boolean") for i, v in enumerate(inst.outputs[t])}
             for name, inst in ex.instances.items()}
    ex.close()
    ours = log_reader.read(log)
    for name, values in final.items():
        pb = protobuf_messages(log, f"/{name}")
        assert len(pb) == len(ours[f"/{name}"]) == 101  # t = 0, then 100 steps
        for key, value in values.items():
            assert getattr(pb[-1], key) == value == ours[f"/{name}"][-1][key], (name, key)
    assert math.isclose(ours["/plant"][-1]["t"], 1.2) and ours["/controller"][-1]["t"] == pytest.approx(1.188)
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

"""The shipped Foxglove layout is current and plots paths the log has."""

from __future__ import annotations

import json

from support import ROOT
from tiltload.master.app.loop.scene import scene_channels
from tiltload.master.app.loop.thesis import default_system
from tiltload.master.app.views import foxglove_layout
from tiltload.master.engine.execution import Execution
from tiltload.master.engine.log import reader as log_reader
from tiltload.master.engine.log.logger import McapLogger


def test_the_shipped_foxglove_layout_is_current_and_plots_paths_the_log_has(fmus, tmp_path):
    assert (ROOT / "docs" / "foxglove_layout.json").read_text() == foxglove_layout.layout_json()
    layout = json.loads(foxglove_layout.layout_json())
    values = []

    def walk(node):
        if isinstance(node, dict):
            if "value" in node and isinstance(node["value"], str):
                values.append(node["value"])
            for v in node.values():
                walk(v)
        elif isinstance(node, list):
            for v in node:
                walk(v)
    walk(layout)
    assert len(values) == sum(len(s) for s in foxglove_layout.PATHS.values())
    log = tmp_path / "run.mcap"
    ex = Execution(default_system(fmus, "zse", 1, "mixed"), [McapLogger(log, derived=scene_channels("plant"))])
    ex.instantiate()
    ex.run(0.12)
    ex.close()
    data = log_reader.read(log)
    for path in values:
        topic, field = path.split(".", 1)
        assert field in data[topic][-1], path
    assert "/scene" in json.dumps(layout) and data["/scene"]

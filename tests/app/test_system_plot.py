"""`tiltload run --system FILE` draws its FMUs' outputs (views/system_plot.py): it used to end in "unexpected failure, a
bug (... has no /plant channel: not a tiltload loop log)", exit 1, after a run that had succeeded, unless --no-plots."""

from __future__ import annotations

import json

import matplotlib.image as mpimg
from support.every_type_fmu import every_type_fmu
from tiltload.master.app.cli import main


def test_a_system_run_draws_each_fmu_s_outputs_and_exits_0(tmp_path, capsys):
    fmu = every_type_fmu(tmp_path, 3)
    system = tmp_path / "pair.json"
    system.write_text(json.dumps({"tick": 0.1, "instances": [
        {"name": "a", "fmu": str(fmu), "parameters": {"u_Int16": 300}}, {"name": "b", "fmu": str(fmu)}],
        "connections": [{"source": "a.y_Int16", "target": "b.u_Float64"}]}))
    assert main(["run", "--system", str(system), "--stop-time", "0.5", "--out", str(tmp_path / "out")]) == 0
    said = capsys.readouterr()
    figure = tmp_path / "out" / "pair_t0.5s_outputs.png"
    assert f"plots: {figure}" in said.out and "a bug" not in said.err
    height, width, _ = mpimg.imread(figure).shape
    assert width > 600 and height > 2 * 200  # two panels, one per FMU

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


def test_a_system_run_s_report_shows_the_figure_of_each_fmu_s_outputs(tmp_path):
    """Its --report page carries the same figure inline (it used to carry none: the report's figures were the loop's)."""
    import base64
    import io
    import re

    fmu = every_type_fmu(tmp_path, 3)
    system = tmp_path / "pair.json"
    system.write_text(json.dumps({"tick": 0.1, "instances": [{"name": "a", "fmu": str(fmu)}, {"name": "b", "fmu": str(fmu)}],
                                  "connections": [{"source": "a.y_Int16", "target": "b.u_Float64"}]}))
    page = tmp_path / "report.html"
    assert main(["run", "--system", str(system), "--stop-time", "0.5", "--out", str(tmp_path / "out"), "--no-plots",
                 "--report", str(page)]) == 0
    html = page.read_text()
    assert re.search(r'<summary>Standard figures \(1\)</summary>\s*<div class="figs">\s*<figure><img alt="Each FMU&#39;s outputs"', html)
    pngs = re.findall(r'src="data:image/png;base64,([^"]+)"', html)
    assert len(pngs) == 1
    height, width, _ = mpimg.imread(io.BytesIO(base64.b64decode(pngs[0]))).shape
    assert width > 400 and height > 2 * 130  # two panels at the page's resolution

"""Issue 61: progress and summary from one clock that includes start-up. A run's bar ends on the figures its summary
prints (it said 180x where the summary said 35x: its clock started after loading); a short run's wall time is not
"0.0 s"; a campaign's elapsed time counts from its start, the cluster's start included and said; a search says
"1 simulation" and each of its status lines once."""

from __future__ import annotations

import io
import re
import sys
import time

import pytest
from tiltload.master.app.campaign import runner as campaign
from tiltload.master.app.cli import main


class Terminal(io.StringIO):
    """stderr as a terminal: the progress bar draws its frames."""

    def isatty(self) -> bool:
        return True


@pytest.mark.parametrize("stop", ["0.3", "2"])
def test_a_run_s_bar_ends_on_its_summary_s_figures(fmus, tmp_path, capsys, monkeypatch, stop):
    capsys.readouterr()
    bar = Terminal()
    monkeypatch.setattr(sys, "stderr", bar)
    assert main(["run", "--scenario", "fsi", "--trajectory", "1", "--stop-time", stop, "--fmus", str(fmus), "--no-log",
                 "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    said = re.search(r"([\d.]+) s simulated in ([\d.e-]+) s \(([\d.]+)x real time\)", out)
    assert said, out
    frames = bar.getvalue().split("\r")
    last = re.search(r"t = +([\d.]+) of [\d.]+ s +\(([\d.]+)x real time", frames[-1])
    assert last, frames[-1]
    assert last.group(2) == said.group(3)  # the same speed, from the same clock
    assert float(last.group(1)) == pytest.approx(float(said.group(1)), abs=0.006)  # at the same simulated time
    wall = float(said.group(2))
    assert wall > 0 and float(said.group(1)) / wall == pytest.approx(float(said.group(3)), rel=0.1, abs=0.6)


@pytest.mark.slow
def test_a_campaign_s_elapsed_time_counts_from_its_start_the_cluster_s_included(fmus, tmp_path, monkeypatch):
    from tiltload.master.app.batch import cluster

    start = cluster.local_cluster

    def slow_start(*args, **kwargs):  # a cluster that takes 3 s to start, as on a loaded machine
        time.sleep(3.0)
        return start(*args, **kwargs)
    monkeypatch.setattr(cluster, "local_cluster", slow_start)
    spec = tmp_path / "c.toml"
    spec.write_text('name = "clock"\n[base]\nscenario = "fsi"\ntrajectory = 1\ncontrollers = ["dlqr"]\nstop_time = 0.5\n'
                    '[vary]\nseeds = [1, 2]\n')
    lines = []
    began = time.perf_counter()
    campaign.run(spec, tmp_path / "out", fmus=fmus, workers=1, progress=lambda line: lines.append((time.perf_counter(), line)))
    said = [line for _, line in lines]
    starting = next(i for i, line in enumerate(said) if line.startswith("starting a local Dask cluster"))
    ready = next(i for i, line in enumerate(said) if "cluster ready" in line)
    assert starting < ready
    runs = [(at, int(m.group(1))) for at, line in lines for m in [re.search(r"runs \(.*\), (\d+) s, ", line)] if m]
    assert runs and all(elapsed >= 3 for _, elapsed in runs)
    for at, elapsed in runs:  # the figure is the time since the campaign began (whole seconds), not since its dispatch
        assert abs(elapsed - (at - began)) <= 1.5, (elapsed, at - began, said)


@pytest.mark.slow
def test_a_search_says_one_simulation_and_each_status_line_once(fmus, tmp_path, capfd):
    spec = tmp_path / "f.toml"
    spec.write_text("""
name = "once"
optimizer = "uniform"
[base]
scenario = "fsi"
trajectory = 1
stop_time = 2.1
gusts = false
[[requirements]]
name = "swing"
formula = "always[1:2] (abs(plant.gamma_1) < 5)"
[[search]]
name = "amp"
target = "gust.amplitude"
range = [0.0, 1.0]
[gust]
start = 1.2
duration = 0.5
[budget]
simulations = 1
""")
    main(["falsify", str(spec), "--out", str(tmp_path / "out"), "--fmus", str(fmus), "--workers", "1", "--branch", "off"])
    both = capfd.readouterr()
    text = both.out + both.err
    assert "1 simulations" not in text and "NOT FALSIFIED in 1 simulation " in text
    status = [line for line in text.splitlines() if line.startswith(("early stop", "branching from a snapshot"))]
    assert len(status) == 2 and len(set(status)) == 2, text

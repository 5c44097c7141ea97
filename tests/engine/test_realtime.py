"""Real-time pacing: absolute deadlines on the monotonic clock, overruns counted and budgeted, results unchanged."""

from __future__ import annotations

import time

import pytest
from tiltload.master.app.cli import main
from tiltload.master.app.loop.thesis import default_system, loop_metrics
from tiltload.master.engine.log import reader as log_reader
from tiltload.master.engine.realtime import Pacer
from tiltload.master.engine.run import run_system


def test_a_paced_run_keeps_to_the_clock_and_computes_the_same_numbers(fmus, tmp_path):
    stop, factor = 1.2, 4.0  # 100 ticks in 0.3 s of wall time
    free = run_system(default_system(fmus, "fsi", 1, "dlqr"), stop, None, loop_metrics(), progress=False)
    pacer = Pacer(factor)
    started = time.perf_counter()
    paced = run_system(default_system(fmus, "fsi", 1, "dlqr"), stop, tmp_path / "paced.mcap", loop_metrics(), progress=False,
                       realtime=pacer)
    wall = time.perf_counter() - started
    assert paced.error is None and paced.metrics == free.metrics  # bit for bit: pacing only waits
    assert wall >= (stop - 0.012) / factor  # the last tick starts at (n - 1) T / factor after the first
    s = pacer.statistics()
    assert s["ticks"] == 100 and 0 <= s["lateness_p50"] <= s["lateness_p99"] <= s["worst_lateness"]
    record = log_reader.read_metadata(tmp_path / "paced.mcap")["realtime"]
    assert int(record["ticks"]) == 100 and float(record["factor"]) == factor


def test_an_overrun_budget_stops_the_run_with_one_line(fmus, tmp_path, capsys):
    """At 1000 times real time (the largest factor --realtime takes) every tick is late, the loop with its log running at
    about 500x here: a budget of 5 overruns ends the run in one line, log kept."""
    code = main(["run", "--scenario", "fsi", "--controller", "dlqr", "--stop-time", "1.2", "--realtime", "1000",
                 "--max-overruns", "5", "--fmus", str(fmus), "--out", str(tmp_path), "--quiet", "--no-plots"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1 and len(err) == 1 and "ticks missed their deadline, more than the --max-overruns 5" in err[0], err
    assert "the log is readable up to" in err[0]


@pytest.mark.parametrize("argv, needle", [(["--realtime", "0"], "must be a positive finite number"),
                                          (["--realtime", "nan"], "must be a positive finite number"),
                                          (["--realtime", "1", "--max-overruns", "-1"], "must be a whole number >= 0")])
def test_bad_pacing_options_are_one_line(capsys, argv, needle):
    with pytest.raises(SystemExit) as exit_:
        main(["run", "--stop-time", "0.1", *argv])
    err = capsys.readouterr().err.strip().splitlines()
    assert exit_.value.code == 2 and len(err) == 1 and needle in err[0], err


def test_an_overrun_budget_without_pacing_is_refused(fmus, tmp_path, capsys):
    code = main(["run", "--stop-time", "0.1", "--max-overruns", "3", "--fmus", str(fmus), "--out", str(tmp_path), "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and err == ["tiltload: error: --max-overruns needs --realtime"], err

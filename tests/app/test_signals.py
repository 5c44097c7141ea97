"""Signals: SIGINT and SIGTERM finalize the log; after SIGKILL the torn log reads, plots and compares."""

from __future__ import annotations

import random
import signal
import struct
import subprocess
import sys
import time
from pathlib import Path

import pytest
from support import HOSTS
from tiltload.master.app.cli import main
from tiltload.master.app.loop.thesis import loop_metrics
from tiltload.master.engine.log import reader as log_reader


def start(fmus: Path, folder: Path) -> tuple[subprocess.Popen, Path, Path]:
    clock = folder / "clock"
    clock.write_bytes(b"\0" * 8)
    log = folder / "run.mcap"
    # SIGINT at its default, as in a terminal: a shell without job control starts background jobs (a CI script's
    # `cmd &`) with SIGINT ignored, the child inherits that, and Python then leaves Ctrl-C ignored
    proc = subprocess.Popen([sys.executable, str(HOSTS / "kill_target.py"), str(fmus), str(log), str(clock)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    return proc, log, clock


def wait_until(clock: Path, proc, t: float) -> float:
    deadline = time.time() + 120
    while (now := struct.unpack("d", clock.read_bytes()[:8])[0]) < t:
        assert proc.poll() is None and time.time() < deadline, proc.stderr.read() if proc.poll() is not None else "timeout"
        time.sleep(0.001)
    return now


@pytest.mark.parametrize("signum, code, name", [(signal.SIGINT, 130, "SIGINT"), (signal.SIGTERM, 143, "SIGTERM")])
@pytest.mark.parametrize("seed", [1, 2])
@pytest.mark.slow
def test_sigint_and_sigterm_finalize_the_log(fmus, tmp_path, signum, code, name, seed):
    proc, log, clock = start(fmus, tmp_path)
    wait_until(clock, proc, random.Random(seed).uniform(0.5, 6.0))
    proc.send_signal(signum)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == code, err
    assert out.strip().startswith(f"interrupted by {name} at t = ") and "Traceback" not in err
    stopped = float(out.split("t = ")[1].split()[0])
    assert not log_reader.is_truncated(log) and not (tmp_path / "run.mcap.partial").exists()  # closed and moved into place
    plant = log_reader.read(log, topics=["/plant"])["/plant"]
    assert abs(plant[-1]["t"] - stopped) <= 0.012 + 1e-9  # everything up to the interrupted tick is there
    assert log_reader.read_metadata(log)["error"]["message"].startswith(f"interrupted by {name}")


@pytest.mark.parametrize("seed", [1, 2, 3])
@pytest.mark.slow
def test_after_sigkill_the_torn_log_reads_plots_and_compares(fmus, tmp_path, capsys, seed):
    earlier = tmp_path / "run.mcap"
    earlier.write_bytes(b"an earlier log")  # a kill must not destroy a previous run's log of the same name
    proc, log, clock = start(fmus, tmp_path)
    wait_until(clock, proc, random.Random(seed).uniform(1.0, 8.0))
    proc.kill()
    proc.communicate(timeout=60)
    killed_at = struct.unpack("d", clock.read_bytes()[:8])[0]
    assert earlier.read_bytes() == b"an earlier log"
    torn = tmp_path / "run.mcap.partial"
    data, truncated = log_reader.read_log(torn)
    # lost: the chunk being filled (32 KiB, the loop running tick by tick: 13 ticks, 0.156 s) and the tick in hand
    assert truncated and killed_at - data["/plant"][-1]["t"] <= 0.25, (killed_at, data["/plant"][-1]["t"])
    assert main(["plot", str(torn), "--out", str(tmp_path / "plots")]) == 0
    assert "is truncated" in capsys.readouterr().out and len(list((tmp_path / "plots").glob("*.png"))) == 7
    code = main(["compare", str(torn), str(torn)])
    out, err = capsys.readouterr()
    assert code == 0 and "metrics recomputed from its messages up to t =" in out and "ISE(x)" in out and not err


def test_metrics_recomputed_from_a_log_equal_the_runs_own(fmus, tmp_path):
    """The recomputation a torn log relies on, checked on a complete run against the Metrics observer."""
    from tiltload.master.app.loop.thesis import default_system
    from tiltload.master.app.regression.log_metrics import metrics_from_messages
    from tiltload.master.engine.run import run_system

    res = run_system(default_system(fmus, "zse", 1, "mixed"), 3.0, tmp_path / "m.mcap", loop_metrics(),
                     progress=False)
    again, last = metrics_from_messages(log_reader.read(res.log), end=3.0)  # the closing samples at 3 s start no tick
    assert last == pytest.approx(2.988)
    for key, value in res.metrics.items():
        assert again[key] == pytest.approx(value, rel=1e-12, abs=1e-15), key

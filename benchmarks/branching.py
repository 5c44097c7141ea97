"""What a branch from a snapshot saves: starting 10 s of ZSE loop from a snapshot at 20 s against rerunning 0-30 s.

Printed: the snapshot's size, the time to take and write it, to read it and restore it into a fresh set of FMU
instances (instantiate + initialize + restore), and the wall time of a branch (restore + 10 s) against a rerun from
t = 0 (instantiate + 30 s), each the best of 3, no log. Then, on a local Dask cluster of 2 workers, a campaign of
50 branches from the snapshot (50 sensor seeds, 20-30 s) against the same 50 runs from t = 0.
Run: python benchmarks/branching.py [--no-campaign]
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

from tiltload.master.app.loop.fmus import build_all
from tiltload.master.app.loop.thesis import default_system, loop_metrics
from tiltload.master.engine import snapshot
from tiltload.master.engine.execution import Execution

AT, STOP = 20.0, 30.0


def best(fn, n=3):
    return min(fn() for _ in range(n))


def main() -> None:
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    fmus = Path("fmus")
    build_all(fmus)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "at20.snapshot"
        ex = Execution(default_system(fmus, "zse", 1, "mixed"), [loop_metrics()])
        ex.instantiate()
        ex.run(AT)
        started = time.perf_counter()
        snapshot.write(snapshot.take(ex), path)
        take = time.perf_counter() - started
        ex.close()

        def rerun():
            t0 = time.perf_counter()
            e = Execution(default_system(fmus, "zse", 1, "mixed"), [loop_metrics()])
            e.instantiate()
            e.run(STOP)
            e.close()
            return time.perf_counter() - t0

        def branch(run=True):
            t0 = time.perf_counter()
            snap = snapshot.read(path)
            e = Execution(default_system(fmus, "zse", 1, "mixed"), [loop_metrics()])
            e.instantiate(resume=snap)
            restored = time.perf_counter() - t0
            if run:
                e.run(STOP)
            e.close()
            return time.perf_counter() - t0 if run else restored
        restore = best(lambda: branch(False))
        size = path.stat().st_size
        b, r = best(branch), best(rerun)
    print(f"ZSE loop, snapshot at {AT:g} s, {STOP:g} s in all (this machine: {os.cpu_count()} cores)")
    print(f"snapshot: {size / 1e3:.0f} kB written in {take * 1e3:.0f} ms; "
          f"read + instantiate + restore {restore * 1e3:.0f} ms")
    print(f"branch (restore + {STOP - AT:g} s): {b:.2f} s;  rerun from t = 0 ({STOP:g} s): {r:.2f} s;  "
          f"the branch costs {b / r:.2f} of the rerun")
    if "--no-campaign" not in sys.argv:
        campaign(fmus)


def campaign(fmus: Path, n: int = 50) -> None:
    """n branches of a campaign against the same n runs from t = 0, both on 2 local workers."""
    from tiltload.master.app.campaign import runner
    from tiltload.master.app.cli import main as cli

    seeds = ", ".join(map(str, range(1, n + 1)))
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        assert cli(["run", "--scenario", "zse", "--controller", "mixed", "--stop-time", f"{STOP:g}", "--snapshot-at",
                    f"{AT:g}", str(tmp / "at.snapshot"), "--no-log", "--quiet", "--no-plots", "--fmus", str(fmus)]) == 0
        (tmp / "branches.toml").write_text(f'name = "branches"\n[base]\nsnapshot = "at.snapshot"\nstop_time = {STOP}\n'
                                           f"[vary]\nseeds = [{seeds}]\n")
        (tmp / "reruns.toml").write_text(f'name = "reruns"\n[base]\nscenario = "zse"\ncontrollers = ["mixed"]\n'
                                         f"stop_time = {STOP}\n[vary]\nseeds = [{seeds}]\n")
        seconds = {}
        for name in ("branches", "reruns"):
            _, counts = runner.run(tmp / f"{name}.toml", tmp / name, fmus=fmus, workers=2, progress=lambda _: None)
            assert counts["completed"] == n, counts
            seconds[name] = counts["seconds"]
    print(f"campaign, 2 workers: {n} branches ({AT:g}-{STOP:g} s) in {seconds['branches']:.2f} s; the same {n} runs from "
          f"t = 0 in {seconds['reruns']:.2f} s; branches cost {seconds['branches'] / seconds['reruns']:.2f} of the reruns")


if __name__ == "__main__":
    main()

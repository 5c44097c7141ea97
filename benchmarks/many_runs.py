"""1000 consecutive short runs of the `tiltload` command: how many end abnormally.

Each run is a fresh process (`tiltload run`, 0.5 s of simulated time, no plots), cycling through
scenarios, designs, seeds and controllers: our native controller, a `tiltload wrap` controller in
its own process (the default), and the same wrapped controller trusted into the master's process
(pythonfmu loaded in process: the case that used to crash at interpreter shutdown). A run counts
as an abort if it exits non-zero, dies by a signal, prints a traceback or leaves its log
unfinished. Two runs go at a time (the machine's two cores); the count is of runs, not of pairs.

Run: python benchmarks/many_runs.py [N] [--jobs J]   (about 1.6 s per run and job)
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "docs" / "examples" / "hover_lqr.py"


def command(i: int, fmus: Path, out: Path, wrapped: Path) -> list[str]:
    scenario = ("fsi", "lkf", "zse")[i % 3]
    kind = i % 4
    args = ["tiltload", "run", "--fmus", str(fmus), "--out", str(out), "--name", f"run{i}", "--stop-time", "0.5",
            "--seed", str(i), "--scenario", scenario, "--no-plots", "--quiet"]
    if kind == 0:
        args += ["--controller", "mixed"]
    elif kind == 1:
        args += ["--controller", "dlqr", "--trajectory", "2"]
    elif kind == 2:
        args += ["--controller", str(wrapped), "--trajectory", "0"]
    else:
        args += ["--controller", str(wrapped), "--trajectory", "0", "--trust-fmus"]
    return args


def one(i: int, fmus: Path, out: Path, wrapped: Path) -> tuple[int, int, str]:
    env = dict(os.environ, TMPDIR=str(out.parent / "tmpdir"))  # a private temporary folder: what a run leaves shows
    proc = subprocess.run(command(i, fmus, out, wrapped), capture_output=True, text=True, env=env)
    log = out / f"run{i}.mcap"
    problem = ""
    if proc.returncode != 0:
        problem = f"exit {proc.returncode}: {proc.stderr.strip()[-300:]}"
    elif "Traceback" in proc.stderr:
        problem = "traceback on stderr"
    elif not log.is_file() or (out / f"run{i}.mcap.partial").exists():
        problem = "log missing or unfinished"
    if log.is_file():
        log.unlink()
    return i, proc.returncode, problem


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    ap.add_argument("n", type=int, nargs="?", default=1000)
    ap.add_argument("--jobs", type=int, default=2)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        fmus, out, wrapped = tmp / "fmus", tmp / "runs", tmp / "hover_lqr.fmu"
        (tmp / "tmpdir").mkdir()
        subprocess.run(["tiltload", "build", "--out", str(fmus)], check=True, capture_output=True)
        subprocess.run(["tiltload", "wrap", str(EXAMPLE), "--out", str(wrapped)], check=True, capture_output=True)
        started = time.perf_counter()
        problems, done = [], 0
        with ThreadPoolExecutor(args.jobs) as pool:
            for i, _code, problem in pool.map(lambda i: one(i, fmus, out, wrapped), range(args.n)):
                done += 1
                if problem:
                    problems.append((i, problem))
                    print(f"run {i} ({' '.join(command(i, fmus, out, wrapped)[-3:])}): {problem}", flush=True)
                if done % 50 == 0:
                    print(f"{done}/{args.n} runs, {len(problems)} aborts, {time.perf_counter() - started:.0f} s", flush=True)
        wall = time.perf_counter() - started
        leftovers = os.listdir(tmp / "tmpdir")
    print(f"{args.n} runs in {wall:.0f} s ({wall / args.n:.2f} s per run with {args.jobs} at a time): "
          f"{len(problems)} aborts; {len(leftovers)} entries left in the runs' TMPDIR")
    return 1 if problems or leftovers else 0


if __name__ == "__main__":
    sys.exit(main())

"""What the tiltload pytest plugin (loaded in every pytest run once tiltload is installed) costs tiltload's own suite:
the collection of a test folder with the plugin and without it (-p no:tiltload), alternated, median of N each.

Run: python benchmarks/pytest_plugin.py [--tests tests/app] [--repeat 5]
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time
from pathlib import Path

from timing import machine

ROOT = Path(__file__).resolve().parent.parent


def collect(tests: str, plugin: bool) -> tuple[float, str]:
    argv = [sys.executable, "-m", "pytest", "--collect-only", "-q", "-p", "no:cacheprovider", tests]
    if not plugin:
        argv[3:3] = ["-p", "no:tiltload"]
    started = time.perf_counter()
    done = subprocess.run(argv, capture_output=True, text=True, cwd=ROOT)
    wall = time.perf_counter() - started
    if done.returncode != 0:
        raise SystemExit(done.stdout[-2000:] + done.stderr[-2000:])
    return wall, done.stdout.strip().splitlines()[-1]


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    p.add_argument("--tests", default="tests/app")
    p.add_argument("--repeat", type=int, default=5)
    a = p.parse_args()
    times: dict[bool, list[float]] = {True: [], False: []}
    said = {}
    for _ in range(a.repeat):
        for plugin in (True, False):
            wall, said[plugin] = collect(a.tests, plugin)
            times[plugin].append(wall)
    print(machine())
    for plugin in (True, False):
        print(f"collect {a.tests} {'with' if plugin else 'without'} the plugin: median {statistics.median(times[plugin]):.2f} s "
              f"(min {min(times[plugin]):.2f}, max {max(times[plugin]):.2f}; {said[plugin]})")
    print(f"difference of the medians: {statistics.median(times[True]) - statistics.median(times[False]):+.2f} s")
    return 0 if said[True] == said[False] else 1  # the same tests collected both ways


if __name__ == "__main__":
    sys.exit(main())

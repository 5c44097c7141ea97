"""The twelve reproduction cases through the public API (tiltload.run) and through the command (`tiltload run`, a
process each), side by side: the metrics bit for bit equal or not, each case's wall time both ways, and the API's
metrics against the committed baselines/ (within their tolerances).

Run: python benchmarks/api_vs_cli.py [--fmus DIR] [--stop-time S] [--cases N]
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import tiltload as tl
from tiltload.master.app.api.command_line import options_argv
from tiltload.master.app.regression.compare import load_metrics
from tiltload.master.app.regression.reproduce import CASES, case_name
from timing import machine

ROOT = Path(__file__).resolve().parent.parent


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    p.add_argument("--fmus", type=Path, default=ROOT / "fmus")
    p.add_argument("--stop-time", type=float, default=None, help="s (default: each case's full length)")
    p.add_argument("--cases", type=int, default=len(CASES), help="the first N of the twelve")
    a = p.parse_args()
    tiltload = str(Path(sys.executable).parent / "tiltload")
    print(f"{machine()}; stop time {a.stop_time or 'full'}")
    print(f"{'case':<18} {'metrics equal':>13} {'API s':>7} {'CLI s':>7}  baseline")
    equal_cases = 0
    with tempfile.TemporaryDirectory() as tmp:
        for scenario, trajectory, controller in CASES[:a.cases]:
            options = {"scenario": scenario, "trajectory": trajectory, "controller": controller, "fmus": a.fmus.resolve(),
                       "stop_time": a.stop_time, "no_plots": True}
            started = time.perf_counter()
            result = tl.run(out=Path(tmp) / "api", **options)
            api_wall = time.perf_counter() - started
            started = time.perf_counter()
            cli_options = replace(result.options, out=Path(tmp) / "cli", quiet=False)  # the same objects, as a command line
            subprocess.run([tiltload, "run", *options_argv(result.case), *options_argv(cli_options), "--quiet"],
                           check=True, capture_output=True)
            cli_wall = time.perf_counter() - started
            cli_metrics = load_metrics(Path(tmp) / "cli" / result.log.name)[0]
            same = sum(cli_metrics[k] == v for k, v in result.metrics.items())
            equal_cases += same == len(result.metrics) == len(cli_metrics)
            baseline = "n/a (not the full length)"
            if a.stop_time is None:
                baseline = "ok" if tl.compare(result, ROOT / "baselines" / f"{case_name(scenario, trajectory, controller)}.json").ok \
                    else "DIFFERS"
            print(f"{case_name(scenario, trajectory, controller):<18} {same:>6} of {len(result.metrics):<3} {api_wall:>7.1f} "
                  f"{cli_wall:>7.1f}  {baseline}", flush=True)
    print(f"{equal_cases} of {a.cases} cases: the API's metrics equal the command's bit for bit")
    return 0 if equal_cases == a.cases else 1


if __name__ == "__main__":
    sys.exit(main())

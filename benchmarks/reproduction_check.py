"""The twelve reproduction cases against the committed baselines/: within their tolerances, and how many metrics are
bit for bit the baseline's.

Runs the cases as `tiltload reproduce --check` does (master/app/regression/reproduce.py: seed 1, each case's full
length, one process per core, full log), then prints per case the metrics equal to the baseline to the last bit, the
largest relative difference, and whether the case is within its tolerances (the check `--check` makes; exit 1 if
not). The baselines hold the metrics of the FMUs and designs of their day: a difference within the tolerance can come
from a rebuilt FMU or a re-synthesized design as well as from the master. To tell the master's part, --save writes the
metrics (exact floats) to a JSON file and --against compares them to the bit with such a file written by another
checkout on the same FMUs and designs (run this script with that checkout's Python, --fmus pointing at one folder).

Run: python benchmarks/reproduction_check.py [--workers N] [--fmus DIR [--no-build]] [--save FILE] [--against FILE]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import tempfile
from pathlib import Path

from tiltload.master.app.loop.fmus import build_all
from tiltload.master.app.regression import compare as cmp
from tiltload.master.app.regression.reproduce import BASELINE_RTOL, check_baselines, run_all
from timing import machine

BASELINES = Path(__file__).resolve().parent.parent / "baselines"


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    p.add_argument("--workers", type=int, default=None, help="processes (default: one per core)")
    p.add_argument("--fmus", type=Path, default=Path("fmus"), help="FMU folder (default fmus; built if stale)")
    p.add_argument("--no-build", action="store_true", help="run the FMUs in --fmus as they are (another checkout's)")
    p.add_argument("--save", type=Path, help="write every case's metrics to this JSON file")
    p.add_argument("--against", type=Path, help="a --save file of another checkout: say which cases differ from it")
    args = p.parse_args()
    other = None
    if args.against is not None:
        try:
            other = json.loads(args.against.read_text())
        except (OSError, ValueError) as err:
            p.error(f"--against {args.against}: {err}")
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    fmus = args.fmus
    if not args.no_build:
        build_all(fmus, progress=lambda _: None)
    print(machine())
    with tempfile.TemporaryDirectory() as tmp:
        results = run_all(fmus, Path(tmp), args.workers, echo=lambda _: None)
    failed = [r["case"] for r in results if r["error"] is not None]
    exact_cases = 0
    print(f"\n{'case':<18} {'bit for bit':>11} {'max rel diff':>13}  within tolerance")
    for r in results:
        if r["error"] is not None:
            print(f"{r['case']:<18} {'-':>11} {'-':>13}  FAILED: {r['error']}")
            continue
        base, tolerances = cmp.load_metrics(BASELINES / f"{r['case']}.json")
        ok, _ = cmp.compare(r["metrics"], base, BASELINE_RTOL, 1e-12, tolerances)
        exact = sum(r["metrics"].get(k) == v for k, v in base.items())
        rel = max((abs(r["metrics"][k] - v) / abs(v) if v else abs(r["metrics"][k]) for k, v in base.items()
                   if k in r["metrics"]), default=math.nan)
        exact_cases += exact == len(base)
        print(f"{r['case']:<18} {f'{exact}/{len(base)}':>11} {rel:>13.2e}  {'yes' if ok else 'NO'}")
    if args.save is not None:
        args.save.write_text(json.dumps({r["case"]: r["metrics"] for r in results if r["error"] is None}, indent=1) + "\n")
    differ = []
    if other is not None:
        differ = [r["case"] for r in results if r["error"] is None and other.get(r["case"]) != r["metrics"]]
        print(f"against {args.against}: " + (f"{len(differ)} case(s) differ: {', '.join(differ)}" if differ
                                              else f"all {len(results) - len(failed)} cases bit for bit equal"))
    ok = not failed and check_baselines([r for r in results if r["error"] is None], BASELINES, echo=lambda _: None)
    print(f"\n{len(results)} cases: {exact_cases} bit for bit their baseline; "
          + ("all within their tolerances (tiltload reproduce --check passes)" if ok else "DIFFERENCES: tiltload reproduce --check fails"))
    return 0 if ok and not differ else 1


if __name__ == "__main__":
    sys.exit(main())

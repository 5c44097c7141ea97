"""How far the twelve baseline metrics move on another machine, emulated on this one.

Each variant rebuilds everything from scratch (empty design cache, no shipped designs, new FMUs) in a child
process whose environment changes what differs between machines:
  - OpenBLAS kernels (OPENBLAS_CORETYPE): numpy/scipy (DARE, ZOH, estimator set-up) and SDPA's
    own OpenBLAS round differently per CPU family;
  - no AVX2/FMA: the controller's estimator kernels without their AVX2 copy
    (TILTLOAD_CFLAGS=-DTL_PORTABLE_FP) and glibc's libm without its FMA variants (GLIBC_TUNABLES);
  - one thread everywhere (SDPA, BLAS).
It prints, per case and metric, the largest relative deviation from the reference variant, and
with --write-tolerances stores rtol = max(FLOOR, SAFETY x spread) per metric in baselines/.

Run: python benchmarks/baseline_spread.py [--write-tolerances]   (per variant: docs/timings.md)
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
VARIANTS = {
    "reference": {},
    "openblas-prescott": {"OPENBLAS_CORETYPE": "Prescott"},
    "openblas-sandybridge": {"OPENBLAS_CORETYPE": "Sandybridge"},
    "openblas-haswell": {"OPENBLAS_CORETYPE": "Haswell"},
    "no-avx2-fma": {"TILTLOAD_CFLAGS": "-DTL_PORTABLE_FP", "GLIBC_TUNABLES": "glibc.cpu.hwcaps=-AVX2,-FMA,-AVX512F"},
    "one-thread": {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "TILTLOAD_SOLVER_THREADS": "1"},
}
SAFETY = 100.0  # tolerance = SAFETY x the spread measured here (machines this one cannot emulate: ARM, other compilers)
FLOOR = 1e-6  # ... and never tighter than this


def run_variant(name: str, result: Path) -> None:
    """Child: build the FMUs into a fresh folder with a fresh cache, run the twelve cases, dump the metrics."""
    from tiltload.master.app.loop.fmus import build_all
    from tiltload.master.app.regression.reproduce import run_all

    with tempfile.TemporaryDirectory(prefix=f"tiltload_spread_{name}_") as tmp:
        os.environ["TILTLOAD_CACHE"] = str(Path(tmp) / "cache")
        build_all(Path(tmp) / "fmus", progress=lambda m: print(f"  [{name}] {m}", file=sys.stderr))
        results = run_all(Path(tmp) / "fmus", Path(tmp) / "runs", echo=lambda m: print(f"  [{name}] {m}", file=sys.stderr))
    failed = [r["case"] for r in results if r["error"] is not None]
    if failed:
        raise SystemExit(f"{name}: cases failed: {', '.join(failed)}")
    result.write_text(json.dumps({r["case"]: r["metrics"] for r in results}, indent=1))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    ap.add_argument("--variant", help=argparse.SUPPRESS)  # child mode
    ap.add_argument("--result", type=Path, help=argparse.SUPPRESS)
    ap.add_argument("--only", nargs="*", default=list(VARIANTS), help="variants to run (default: all)")
    ap.add_argument("--write-tolerances", action="store_true", help="store per-metric rtol in baselines/*.json")
    args = ap.parse_args()
    if args.variant:
        run_variant(args.variant, args.result)
        return 0
    metrics = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.only:
            started = time.perf_counter()
            out = Path(tmp) / f"{name}.json"
            env = dict(os.environ, **VARIANTS[name], TILTLOAD_SHIPPED_DESIGNS="0")  # each variant synthesizes its designs
            subprocess.run([sys.executable, __file__, "--variant", name, "--result", str(out)], env=env, check=True)
            metrics[name] = json.loads(out.read_text())
            print(f"{name}: {time.perf_counter() - started:.0f} s", flush=True)
    ref = metrics["reference"]
    spread = {case: {k: 0.0 for k in m} for case, m in ref.items()}
    print(f"\nlargest relative deviation from the reference over {len(metrics) - 1} variants")
    for m in metrics.values():
        for case, values in m.items():
            for k, v in values.items():
                r = ref[case][k]
                spread[case][k] = max(spread[case][k], abs(v - r) / max(abs(r), 1e-300))
    keys = list(next(iter(ref.values())))
    print(f"{'case':<18}" + "".join(f"{k:>13}" for k in keys))
    for case in sorted(spread):
        print(f"{case:<18}" + "".join(f"{spread[case][k]:13.1e}" for k in keys))
    worst = max(v for row in spread.values() for v in row.values())
    print(f"worst: {worst:.2e}")
    if args.write_tolerances:
        for case, row in spread.items():
            path = ROOT / "baselines" / f"{case}.json"
            base = json.loads(path.read_text())
            base["tolerances"] = {"atol": 1e-12, **{k: {"rtol": float(f"{max(FLOOR, SAFETY * s):.1e}")} for k, s in row.items()}}
            base["spread"] = {"variants": list(metrics), "max_relative": row}
            path.write_text(json.dumps(base, indent=1) + "\n")
        print("wrote per-metric tolerances to baselines/")
    return 0


if __name__ == "__main__":
    sys.exit(main())

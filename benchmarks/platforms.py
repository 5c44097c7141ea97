"""Build time of every FMU's binaries for every platform (docs/platforms.md, Build time).

The nine FMUs are built once (fmus/, only if stale) for their sources/; then each FMU's sources/ is compiled and
linked again for each platform whose compiler is here, exactly as the builder does (native_fmu.compile.
compile_shared: the builder's flags), twice: one file at a time (one job) and the files in parallel (one job per
core, the builder's default). Wall time and the compilers' processor time (user + system of the child
processes) per FMU and platform; the machine and its load are printed first (the figures are only comparable
on a quiet machine).

Run: python benchmarks/platforms.py [--repeat N]   (N: runs per figure, the best is kept; default 1)
"""

from __future__ import annotations

import argparse
import os
import platform
import resource
import shutil
import tempfile
import time
import zipfile
from pathlib import Path

from tiltload.master.app.loop.fmus import formation_recipes, loop_recipes
from tiltload.native_fmu import compile as cc
from tiltload.native_fmu.build import build

ROOT = Path(__file__).resolve().parents[1]


def machine() -> str:
    model = next((line.split(":", 1)[1].strip() for line in Path("/proc/cpuinfo").read_text().splitlines()
                  if line.startswith("model name")), platform.processor()) if Path("/proc/cpuinfo").exists() else platform.processor()
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    return f"{model}, {os.cpu_count()} cores, {platform.system()} {platform.release()}; load average {load}"


def children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def timed(sources: Path, work: Path, ident: str, t: cc.Toolchain, jobs: int, repeat: int) -> tuple[float, float]:
    """(best wall s, its processor s) of compiling and linking sources/ for t."""
    best = (float("inf"), 0.0)
    for i in range(repeat):
        out = work / f"{t.folder}_{jobs}_{i}"
        out.mkdir()
        cpu, wall = children_cpu(), time.perf_counter()
        warnings = cc.compile_shared(cc.NativeSources([]), sources, out / f"{ident}{t.suffix}", t, jobs=jobs)
        wall, cpu = time.perf_counter() - wall, children_cpu() - cpu
        assert not warnings, warnings
        best = min(best, (wall, cpu))
        shutil.rmtree(out)
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    parser.add_argument("--repeat", type=int, default=1, help="runs per figure, the best kept (default 1)")
    args = parser.parse_args()
    toolchains, missing = cc.choose()
    print(f"machine: {machine()}")
    for t in toolchains:
        print(f"  {t.folder:14} {cc.compiler_identity(cc.compiler(t))}")
    if missing:
        print(f"  ({missing})")
    recipes = {r.fmu_name: r for r in [*loop_recipes(("load", "uav")), *formation_recipes()]}
    fmus = [build(r, ROOT / "fmus", progress=lambda *_: None).path for r in recipes.values()]
    jobs = os.cpu_count() or 1
    totals = {(t.folder, j): [0.0, 0.0] for t in toolchains for j in (1, jobs)}
    print(f"\n{'FMU':22} {'platform':14} {'1 job: wall':>12} {'cpu':>7} {f'{jobs} jobs: wall':>14} {'cpu':>7}")
    with tempfile.TemporaryDirectory(prefix="tiltload_bench_platforms_") as tmp:
        for fmu in fmus:
            work = Path(tmp) / fmu.stem
            with zipfile.ZipFile(fmu) as z:
                z.extractall(work)
            sources = work / "sources"
            for t in toolchains:
                row = []
                for j in (1, jobs):
                    wall, cpu = timed(sources, work, fmu.stem, t, j, args.repeat)
                    totals[t.folder, j][0] += wall
                    totals[t.folder, j][1] += cpu
                    row += [wall, cpu]
                print(f"{fmu.stem:22} {t.folder:14} {row[0]:11.2f}s {row[1]:6.2f}s {row[2]:13.2f}s {row[3]:6.2f}s")
    print()
    grand = [0.0, 0.0, 0.0, 0.0]
    for t in toolchains:
        one, many = totals[t.folder, 1], totals[t.folder, jobs]
        grand = [grand[0] + one[0], grand[1] + one[1], grand[2] + many[0], grand[3] + many[1]]
        print(f"{'all nine':22} {t.folder:14} {one[0]:11.2f}s {one[1]:6.2f}s {many[0]:13.2f}s {many[1]:6.2f}s")
    print(f"{'all nine':22} {'every platform':14} {grand[0]:11.2f}s {grand[1]:6.2f}s {grand[2]:13.2f}s {grand[3]:6.2f}s")
    print(f"load average after: {', '.join(f'{x:.1f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()

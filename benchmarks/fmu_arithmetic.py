"""The FMUs' own arithmetic, before and after (issue 41): the plant's and the ZSE controller's fmi2DoStep from a C host.

Builds the plant and controller FMUs twice, for this machine only: from a landed commit (--before, default b93cc50;
its sources taken with `git archive` into a temporary folder and built by that tree's own code in a subprocess) and
from this tree; then times their C steps side by side in one run with benchmarks/fmu_arithmetic_host.c (no Python in
the timed process): each FMU instantiated with its start values (the plant at the hover trim, 3 RK4 substeps of 4 ms
per 12 ms step; the controller with the ZSE at the equilibrium's measurements), restored to its initialized state
and stepped --steps times per round, the builds taken in turn (A, B, A, B, ...: the machine is shared): the median
round, and the sum of each step's least time over the rounds ("least": a step interrupted by another process in one
round counts from another, so this one holds when the machine is loaded). Beside the times:
- callgrind's instruction count per step (valgrind, if installed): reproducible where times are not;
- the plant's floating-point operations per step, counted in CasADi's instruction lists of the generated functions
  (one right-hand side, one RK4 substep, the outputs), and the limit they set at the machine's scalar rate (--flops-per-cycle,
  default 4: two multiply and two add pipes, as AMD Zen 3/4 and Intel since Skylake have; no FMA, the arithmetic is
  pinned) at the clock of /proc/cpuinfo; the libm calls (sin, cos) and divisions, slower than that, counted apart;
- the ZSE's limit: its one heavy product, (T M) G over the r generators (r x n x ld multiplies, ld = n padded to 4) at
  two four-wide multiplies per cycle (its multiplies and adds go to separate pipes), at the clock measured by a chain of
  dependent integer adds (one per cycle; x86-64: the boost clock, above /proc/cpuinfo's nominal one) and at that nominal
  one. valgrind does not run AVX-512 code: the instruction counts are those of the AVX2 path on any machine.

Run: python benchmarks/fmu_arithmetic.py [--before b93cc50] [--rounds 9] [--steps 400] [--only controller]
from outside the repository, with it importable as `tiltload` but not as an editable install (which would win over the
trees this script builds): e.g. a folder tiltload/ of links to the repository's packages, on PYTHONPATH.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path
from xml.etree import ElementTree

from timing import machine

REPO = Path(__file__).resolve().parents[1]
HOST = Path(__file__).with_name("fmu_arithmetic_host.c")
FMUS = {"plant": "TiltloadPlant.fmu", "controller": "TiltloadController.fmu"}
TICK = 0.012
# What each FMU's run prints back, to show it did the work meant: the plant's load position, the estimator's generators.
SHOWN = {"plant": ["x", "y", "z"], "controller": ["zse_generators", "zse_G_frobenius"]}

BUILD_SCRIPT = """
import sys
from pathlib import Path
from tiltload.native_fmu.build import build
from tiltload.native_fmu.compile import toolchain
from tiltload.plant_fmu import build as plant
from tiltload.controller_fmu.fmu import build as controller
here = (toolchain("x86_64-linux"),)
for recipe in (plant.recipe(), controller.recipe()):
    build(recipe, Path(sys.argv[1]), force=True, progress=lambda _: None, toolchains=here)
"""


def build_tree(tree: Path, dest: Path, cache: Path) -> dict[str, str]:
    """The two FMUs built by the code of tree (a checkout): its folders become the `tiltload` namespace ahead of ours."""
    shim = dest.parent / f"{dest.name}-shim" / "tiltload"
    shim.mkdir(parents=True)
    for sub in tree.iterdir():
        if (sub / "__init__.py").exists():
            (shim / sub.name).symlink_to(sub)
    env = {**os.environ, "PYTHONPATH": str(shim.parent), "TILTLOAD_CACHE": str(cache)}
    check = "import tiltload.plant_fmu as p; print(p.__file__)"
    where = subprocess.run([sys.executable, "-c", check], env=env, check=True, capture_output=True, text=True).stdout
    if not where.startswith(str(shim)):
        raise SystemExit(f"the build of {tree} would import tiltload from {where.strip()}, not from the tree")
    subprocess.run([sys.executable, "-c", BUILD_SCRIPT, str(dest)], env=env, check=True)
    return env


def unpack(fmu: Path, folder: Path) -> tuple[Path, str, dict[str, int]]:
    """(binary, guid, {variable: value reference}) of an FMU unpacked into folder."""
    with zipfile.ZipFile(fmu) as z:
        z.extractall(folder)
    md = ElementTree.parse(folder / "modelDescription.xml").getroot()
    ident = md.find("CoSimulation").get("modelIdentifier")
    vrs = {v.get("name"): int(v.get("valueReference")) for v in md.iter("ScalarVariable") if v.find("Real") is not None}
    return folder / "binaries" / "linux64" / f"{ident}.so", md.get("guid"), vrs


def compile_host(sources: Path, out: Path) -> Path:
    subprocess.run(["cc", "-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", f"-I{sources}", str(HOST), "-o", str(out), "-ldl"],
                   check=True)
    return out


def run_host(host: Path, fmu, steps: int, rounds: int, shown: list[int]) -> tuple[list[float], list[float], list[list[float]]]:
    """(ns per step of each round, the values shown, each round's per-step ns)."""
    binary, guid, _ = fmu
    out = subprocess.run([str(host), str(binary), guid, str(TICK), str(steps), str(rounds), *map(str, shown)],
                         check=True, capture_output=True, text=True).stdout
    times = [float(line.split()[1]) for line in out.splitlines() if line.startswith("round ")]
    each = [[float(v) for v in line.split()[1:]] for line in out.splitlines() if line.startswith("steps ")]
    values = [float(line.split()[2]) for line in out.splitlines() if line.startswith("value ")]
    return times, values, each


CLOCK_C = r"""
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <time.h>
/* dependent integer adds, one per cycle: the least time of many short windows (the machine is shared) */
int main(void) {
  double best = 1e9, t;
  long x = 0, i;
  int r;
  for (r = 0; r < 4000; ++r) {
    struct timespec a, b;
    clock_gettime(CLOCK_MONOTONIC, &a);
    for (i = 0; i < 25000; ++i) __asm__ volatile("add $1, %0\n\tadd $1, %0\n\tadd $1, %0\n\tadd $1, %0" : "+r"(x));
    clock_gettime(CLOCK_MONOTONIC, &b);
    t = (double)(b.tv_sec - a.tv_sec) + 1e-9 * (double)(b.tv_nsec - a.tv_nsec);
    if (t < best) best = t;
  }
  printf("%.3f\n", 1e5 / best / 1e9);
  return 0;
}
"""


def measured_ghz(folder: Path) -> float | None:
    """The clock the cores run at (x86-64 only: None elsewhere)."""
    if os.uname().machine != "x86_64":
        return None
    (folder / "clock.c").write_text(CLOCK_C)
    subprocess.run(["cc", "-O2", str(folder / "clock.c"), "-o", str(folder / "clock")], check=True)
    return float(subprocess.run([str(folder / "clock")], check=True, capture_output=True, text=True).stdout)


def instructions(host: Path, fmu, steps: int) -> float | None:
    """callgrind's instructions per doStep: the difference of two runs (2 x steps and steps) over steps."""
    if shutil.which("valgrind") is None:
        return None
    counts = []
    for n in (steps, 2 * steps):
        with tempfile.TemporaryDirectory() as tmp:
            binary, guid, _ = fmu
            run = subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={tmp}/cg.out", str(host), str(binary),
                                  guid, str(TICK), str(n), "0"], capture_output=True, text=True, check=True)
            found = re.search(r"Collected : (\d+)", run.stderr)
            if found is None:
                return None
            counts.append(int(found.group(1)))
    return (counts[1] - counts[0]) / steps


COUNT_SCRIPT = """
import casadi as ca
from tiltload.plant_fmu import codegen
skip = {ca.OP_INPUT, ca.OP_OUTPUT, ca.OP_CONST, ca.OP_PARAMETER}
calls = {ca.OP_SIN, ca.OP_COS, ca.OP_TAN, ca.OP_ASIN, ca.OP_ACOS, ca.OP_ATAN, ca.OP_ATAN2, ca.OP_SQRT, ca.OP_EXP, ca.OP_LOG}
for f in codegen.functions():
    f = f if f.is_a("SXFunction") else f.expand()
    ops = [f.instruction_id(k) for k in range(f.n_instructions())]
    print(f.name(), sum(op not in skip for op in ops), sum(op in calls for op in ops), sum(op == ca.OP_DIV for op in ops))
"""


def flop_counts(env: dict[str, str]) -> dict[str, int]:
    """Arithmetic operations of a tree's generated plant functions (CasADi's instruction lists, the RK4 substep expanded;
    inputs, outputs and constants are not operations), and of one 12 ms step as the plant FMU runs it."""
    out = subprocess.run([sys.executable, "-c", COUNT_SCRIPT], env=env, check=True, capture_output=True, text=True).stdout
    named = {line.split()[0]: [int(v) for v in line.split()[1:]] for line in out.splitlines()}
    counts = {"rhs": named["tl_plant_rhs"][0], "rk4": named["tl_plant_rk4"][0], "out": named["tl_plant_out"][0]}
    counts["step"] = 3 * counts["rk4"] + counts["out"]
    counts["calls"] = 3 * named["tl_plant_rk4"][1] + named["tl_plant_out"][1]  # libm calls (sin, cos, atan2...)
    counts["divisions"] = 3 * named["tl_plant_rk4"][2] + named["tl_plant_out"][2]
    return counts


def clock_ghz() -> float:
    mhz = [float(line.split(":")[1]) for line in Path("/proc/cpuinfo").read_text().splitlines() if line.startswith("cpu MHz")]
    return (max(mhz) if mhz else 2000.0) / 1000.0


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    p.add_argument("--before", default="b93cc50", help="the commit to compare with (default b93cc50)")
    p.add_argument("--rounds", type=int, default=9, help="timed rounds per build and FMU, taken in turn (default 9)")
    p.add_argument("--steps", type=int, default=400, help="doSteps per round (default 400: 4.8 s simulated)")
    p.add_argument("--flops-per-cycle", type=float, default=4.0, help="the scalar rate (default 4 per cycle)")
    p.add_argument("--only", choices=sorted(FMUS), help="time this FMU only (both are built)")
    args = p.parse_args()
    if args.rounds < 1 or args.steps < 1 or args.flops_per_cycle <= 0:
        p.error("--rounds and --steps must be >= 1, --flops-per-cycle > 0")
    ghz = clock_ghz()
    rate = args.flops_per_cycle * ghz
    print(machine())
    with tempfile.TemporaryDirectory(prefix="fmu_arithmetic_") as tmp:
        tmp = Path(tmp)
        old_tree = tmp / "before"
        old_tree.mkdir()
        archive = subprocess.run(["git", "-C", str(REPO), "archive", args.before], check=True, capture_output=True).stdout
        subprocess.run(["tar", "-x", "-C", str(old_tree)], input=archive, check=True)
        builds = {"before": tmp / "fmus-before", "after": tmp / "fmus-after"}
        envs = {"before": build_tree(old_tree, builds["before"], tmp / "cache-before"),
                "after": build_tree(REPO, builds["after"], tmp / "cache-after")}
        fmus = {(b, k): unpack(folder / name, tmp / f"{b}-{k}") for b, folder in builds.items() for k, name in FMUS.items()}
        host = compile_host(tmp / "after-plant" / "sources", tmp / "host")
        boost = measured_ghz(tmp)
        kinds = [args.only] if args.only else list(FMUS)
        times: dict = {key: [] for key in fmus}
        least: dict = {key: None for key in fmus}
        shown: dict = {}
        for _ in range(args.rounds):  # in turn, one round each
            for key, fmu in fmus.items():
                if key[1] not in kinds:
                    continue
                t, v, each = run_host(host, fmu, args.steps, 1, [fmu[2][n] for n in SHOWN[key[1]]])
                times[key] += t
                shown[key] = v
                for row in each:
                    least[key] = row if least[key] is None else [min(a, b) for a, b in zip(least[key], row)]
        counts = {b: flop_counts(env) for b, env in envs.items()}
        print(f"\n{args.steps} doSteps of {TICK * 1e3:.0f} ms per round, {args.rounds} rounds taken in turn: the median "
              f"round (the least in brackets), then each step's least time summed ('least'); callgrind instructions per step")
        print(f"{'':>12} {'before ' + args.before:>24} {'after (this tree)':>24} {'after/before':>13}")
        for kind in kinds:
            med = {b: statistics.median(times[(b, kind)]) / 1e3 for b in builds}
            low = {b: min(times[(b, kind)]) / 1e3 for b in builds}
            sure = {b: sum(least[(b, kind)]) / len(least[(b, kind)]) / 1e3 for b in builds}
            ir = {b: instructions(host, fmus[(b, kind)], 50) for b in builds}
            print(f"{kind:>12} " + " ".join(f"{med[b]:>10.2f} us ({low[b]:6.2f})" + " " * 4 for b in builds)
                  + f" {med['after'] / med['before']:>9.2f}x")
            print(f"{'least':>12} " + " ".join(f"{sure[b]:>10.2f} us" + " " * 14 for b in builds)
                  + f" {sure['after'] / sure['before']:>9.2f}x")
            if all(v is not None for v in ir.values()):
                print(f"{'':>12} " + " ".join(f"{ir[b]:>16,.0f} instr  " for b in builds) + f" {ir['after'] / ir['before']:>9.2f}x")
            print(f"{'':>12} values at the end: before {shown[('before', kind)]}, after {shown[('after', kind)]}")
        print(f"\nplant arithmetic (CasADi operations) and its limit at {rate:.1f} scalar operations per ns "
              f"({args.flops_per_cycle:g} per cycle at {ghz:.2f} GHz):")
        for b, c in counts.items():
            print(f"{b:>12} {c['rhs']:>6} per right-hand side, {c['rk4']:>6} per RK4 substep, {c['out']:>5} for the outputs: "
                  f"{c['step']:>6} per 12 ms step (3 substeps + outputs) -> limit {c['step'] / rate / 1e3:.2f} us; "
                  f"besides, {c['calls']} libm calls and {c['divisions']} divisions per step")
        if "controller" in kinds:
            n = 23
            ld = (n + 3) // 4 * 4
            r = int(shown[("after", "controller")][0])
            mults = r * n * ld
            at = f"{mults / 8 / boost / 1e3:.1f} us at the measured {boost:.2f} GHz, " if boost else ""
            print(f"ZSE (T M) G: {r} generators x {n} x {ld} = {mults:,} multiplies (and as many adds) per step -> limit "
                  f"{at}{mults / 8 / ghz / 1e3:.1f} us at the nominal {ghz:.2f} GHz (8 per cycle: two 4-wide multiply pipes)")
    print(f"load average at the end: {', '.join(f'{x:.1f}' for x in os.getloadavg())} (on {os.cpu_count()} cores)")


if __name__ == "__main__":
    main()

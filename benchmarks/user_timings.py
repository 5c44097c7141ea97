"""The times a user meets, measured by running the commands the README names, on this machine.

The figures go to docs/timings.json (with the machine, the date and the load average), docs/timings.md is made from
it, and with --write every figure between <!-- timing:KEY --> and <!-- /timing --> in README.md and docs/*.md is
replaced by the measured one (<!-- timing:install_size -->: the install's environment on disk; <!-- when:KEY -->:
when, where and at what load KEY was measured): no timing in the docs is typed by hand.

  install          `pip install -e .` of a fresh clone into a new virtual environment (no system site-packages,
                   no pip cache), as the README's first command does; also the environment's size on disk
  first_run        a fresh clone of HEAD, `pip install -e` into a new virtual environment, an empty cache:
                   `tiltload run`, timed to its metrics table (three runs, the median; each run also to its first
                   line of output and to its end)
  second_folder    the same in a second fresh clone on a machine whose cache the first clone's run filled (the
                   FMUs come from the machine's FMU cache: no build)
  build            `tiltload build` into an empty fmus/ with an empty cache (nine FMUs)
  design_dlqr, design_hinf, design_mixed       `tiltload design --controller KIND --fresh`
  design_mixed_d1, design_mixed_d2             the mixed design for a loop delay of 1, 2 ticks, synthesized afresh
  reproduce        `tiltload reproduce` (FMUs built beforehand, the machine's cache as a user's: warm)
  campaign         `tiltload campaign docs/campaigns/robustness.toml` (240 runs, FMUs built beforehand, the cache warm;
                   it used to run with an empty cache of its own, so every figure included compiling the tick
                   loop's kernels and unpacking the FMUs again)
  spread_variant   one variant of `python benchmarks/baseline_spread.py` (`--only reference`)

Run: python benchmarks/user_timings.py [--only KEY ...] [--write]
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TIMINGS = ROOT / "docs" / "timings.json"
PAGE = ROOT / "docs" / "timings.md"
MARKER = re.compile(r"<!-- timing:(\w+) -->(.*?)<!-- /timing -->")
WHEN = re.compile(r"<!-- when:(\w+) -->(.*?)<!-- /when -->")
KEYS = ("install", "first_run", "second_folder", "build", "design_dlqr", "design_hinf", "design_mixed", "design_mixed_d1",
        "design_mixed_d2",
        "reproduce", "campaign", "spread_variant")
WHAT = {
    "install": "`pip install -e .` of a fresh clone into a new virtual environment, no pip cache",
    "first_run": "first `tiltload run` of a fresh clone, empty cache, to the metrics table (median of 3)",
    "second_folder": "first `tiltload run` of a second fresh clone, the machine's cache warm, to the metrics table (median of 3)",
    "build": "`tiltload build`, empty fmus/ and cache (nine FMUs)",
    "design_dlqr": "`tiltload design --controller dlqr --fresh`",
    "design_hinf": "`tiltload design --controller hinf --fresh`",
    "design_mixed": "`tiltload design --controller mixed --fresh`",
    "design_mixed_d1": "mixed design for a 1-tick loop delay, synthesized afresh",
    "design_mixed_d2": "mixed design for a 2-tick loop delay, synthesized afresh",
    "reproduce": "`tiltload reproduce` (12 cases, FMUs built, cache warm)",
    "campaign": "`tiltload campaign docs/campaigns/robustness.toml` (240 runs, FMUs built, cache warm)",
    "spread_variant": "one variant of `python benchmarks/baseline_spread.py` (everything rebuilt and synthesized)",
}


def machine() -> str:
    cpu = platform.machine()
    try:
        cpu = next(line.split(":", 1)[1].strip() for line in Path("/proc/cpuinfo").read_text().splitlines()
                   if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    return f"{cpu}, {os.cpu_count()} cores, {platform.system()} {platform.release()}, Python {platform.python_version()}"


def load() -> float:
    return os.getloadavg()[0]


def timed(argv: list[str], cwd: Path, env: dict | None = None, marks: tuple[str, ...] = ()) -> dict:
    """Run argv; the wall time to its end, to its first line of output, and to the first line containing each mark."""
    started = time.perf_counter()
    proc = subprocess.Popen(argv, cwd=cwd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, bufsize=1)
    seen: dict[str, float] = {}
    for line in proc.stdout:
        now = time.perf_counter() - started
        seen.setdefault("first_output", now)
        for mark in marks:
            if mark in line:
                seen.setdefault(mark, now)
    if proc.wait() != 0:
        raise SystemExit(f"{' '.join(argv)} failed (exit {proc.returncode})")
    return {"seconds": time.perf_counter() - started, **seen}


def fresh_venv(venv: Path, clone: Path) -> None:
    """A new virtual environment with the clone installed editable (no dependencies), which sees the dependencies of the
    environment running this: its site-packages folders (a venv whose packages come from another's, through a .pth, has
    them there and not in the interpreter's, which --system-site-packages alone would give)."""
    import site

    subprocess.run([sys.executable, "-m", "venv", "--system-site-packages", str(venv)], check=True)
    ours = [p for p in sys.path if p.endswith("site-packages") and Path(p).is_dir()]
    target = next((venv / "lib").glob("python*/site-packages"))
    (target / "_dependencies.pth").write_text("\n".join(dict.fromkeys([*ours, *site.getsitepackages()])) + "\n")
    subprocess.run([str(venv / "bin" / "pip"), "install", "--quiet", "--no-deps", "-e", str(clone)], check=True)


def first_run(tmp: Path) -> dict:
    runs = []
    for k in range(3):
        clone = tmp / f"clone{k}"
        subprocess.run(["git", "clone", "--quiet", str(ROOT), str(clone)], check=True)
        venv = tmp / f"venv{k}"
        fresh_venv(venv, clone)
        env = dict(os.environ, TILTLOAD_CACHE=str(tmp / f"cache{k}"))
        r = timed([str(venv / "bin" / "tiltload"), "run"], clone, env, marks=("ISE(x)",))
        runs.append({"to_metrics": r["ISE(x)"], "first_output": r["first_output"], "total": r["seconds"]})
        print(f"  first run {k + 1}: first line {r['first_output']:.1f} s, metrics table {r['ISE(x)']:.1f} s, "
              f"end {r['seconds']:.1f} s", flush=True)
    return {"seconds": statistics.median(r["to_metrics"] for r in runs), "runs": runs}


def second_folder(tmp: Path) -> dict:
    """A first clone's run fills a cache; then three more fresh clones, each its first run with that cache."""
    env = dict(os.environ, TILTLOAD_CACHE=str(tmp / "cache"))
    runs = []
    for k in range(4):
        clone, venv = tmp / f"clone{k}", tmp / f"venv{k}"
        subprocess.run(["git", "clone", "--quiet", str(ROOT), str(clone)], check=True)
        fresh_venv(venv, clone)
        r = timed([str(venv / "bin" / "tiltload"), "run"], clone, env, marks=("ISE(x)", "building"))
        if k == 0:
            print(f"  the first clone's run (fills the cache): {r['ISE(x)']:.1f} s to the metrics table", flush=True)
            continue
        if "building" in r:
            raise SystemExit("the second folder's first run built FMUs: the machine's FMU cache was not used")
        runs.append({"to_metrics": r["ISE(x)"], "first_output": r["first_output"], "total": r["seconds"]})
        print(f"  second folder {k}: first line {r['first_output']:.1f} s, metrics table {r['ISE(x)']:.1f} s, "
              f"end {r['seconds']:.1f} s", flush=True)
    return {"seconds": statistics.median(r["to_metrics"] for r in runs), "runs": runs}


def install(tmp: Path) -> dict:
    clone, venv = tmp / "clone-install", tmp / "venv-install"
    subprocess.run(["git", "clone", "--quiet", str(ROOT), str(clone)], check=True)
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    r = timed([str(venv / "bin" / "pip"), "install", "--quiet", "--no-cache-dir", "-e", "."], clone)
    size = sum(p.stat().st_size for p in venv.rglob("*") if p.is_file() and not p.is_symlink())
    print(f"  install: {r['seconds']:.0f} s, the environment {size / 1e9:.2f} GB", flush=True)
    return {"seconds": r["seconds"], "venv_bytes": size}


def with_fmus(tmp: Path) -> Path:
    fmus = tmp / "fmus"
    subprocess.run([sys.executable, "-m", "tiltload.master.app.cli", "build", "--out", str(fmus)], check=True,
                   stdout=subprocess.DEVNULL)
    return fmus


def measure(key: str, tmp: Path) -> dict:
    cli = [sys.executable, "-m", "tiltload.master.app.cli"]
    env = dict(os.environ, TILTLOAD_CACHE=str(tmp / "cache"))
    if key == "install":
        return install(tmp)
    if key == "first_run":
        return first_run(tmp)
    if key == "second_folder":
        return second_folder(tmp)
    if key == "build":
        return timed([*cli, "build", "--out", str(tmp / "fmus-empty")], tmp, env)
    if key.startswith("design_"):
        kind, _, delay = key[len("design_"):].partition("_d")
        if not delay:
            return timed([*cli, "design", "--controller", kind, "--fresh", "--out", str(tmp / "designs")], tmp, env)
        code = f"from tiltload.controller_fmu.design.synthesize import design; design('{kind}', loop_delay={delay})"
        return timed([sys.executable, "-c", code], tmp, env)
    if key == "reproduce":
        fmus = with_fmus(tmp)
        return timed([*cli, "reproduce", "--fmus", str(fmus), "--out", str(tmp / "reproduce")], ROOT)
    if key == "campaign":
        fmus = with_fmus(tmp)
        # --allow-failures: its runs that fail are data, and since the exit codes became a CI's (issue 50) they exit 1
        return timed([*cli, "campaign", str(ROOT / "docs" / "campaigns" / "robustness.toml"), "--fmus", str(fmus),
                      "--out", str(tmp / "campaign"), "--allow-failures"], ROOT)
    if key == "spread_variant":
        return timed([sys.executable, str(ROOT / "benchmarks" / "baseline_spread.py"), "--only", "reference"], ROOT, env)
    raise SystemExit(f"unknown key {key}")


def shown(seconds: float) -> str:
    """A figure as the docs print it."""
    if seconds < 10:
        return f"{seconds:.1f} s"
    if seconds < 120:
        return f"{seconds:.0f} s"
    return f"{seconds / 60:.1f} min"


def render(data: dict) -> str:
    lines = ["# Timings", "",
             "Generated by `python benchmarks/user_timings.py --write` (do not edit by hand): each figure is the wall",
             "time of the command as a user runs it, measured on the machine named with it. The README and the other",
             "pages quote these figures (between `<!-- timing:KEY -->` markers the script rewrites). Absolute times",
             "differ by 2-3x between machines, and with the load of other work on the same one (the load average is",
             "given: on 2 cores, 2 means busy).", "",
             "| what | time | measured on | date | load average |", "|---|---|---|---|---|"]
    for key in KEYS:
        if key in data:
            d = data[key]
            what = WHAT[key] + (f" ({d['venv_bytes'] / 1e9:.1f} GB on disk)" if "venv_bytes" in d else "")
            lines.append(f"| {what} | {shown(d['seconds'])} | {d['machine']} | {d['date']} | {d['load']:.1f} |")
    for key, what in (("first_run", "The three first runs (fresh clone, empty cache)"),
                      ("second_folder", "The three first runs of a second folder (fresh clone, the machine's cache warm)")):
        if key in data:
            lines += ["", f"{what}: to the first line of output, to the metrics table, to the end (figures written):", ""]
            for k, r in enumerate(data[key]["runs"], 1):
                lines.append(f"- run {k}: {r['first_output']:.1f} s, {r['to_metrics']:.1f} s, {r['total']:.1f} s")
    if data.get("scale"):
        lines += ["", "## Scale (`python benchmarks/scale_20k.py --write`)", "",
                  "A campaign of N 2 s runs and a search with a budget of N (uniform, batches of 200), each as `tiltload "
                  "campaign` / `tiltload falsify` on a local cluster of 2 workers. The client's peak resident memory",
                  "(VmHWM: the process that dispatches, stores and assembles, the local cluster's scheduler in it) is "
                  "what shows whether it grows with N: before the report (the runs dispatched and stored, the results assembled) and "
                  "at the end (the report written: the campaign's HTML page lists at most 500 runs, the failing first, and "
                  "counts all); files: everything the command "
                  "wrote (parts among them).", "",
                  "| what | runs | wall | runs a second | client peak RSS before the report | at the end (report written) | "
                  "files (parts) | measured on | date | load average |", "|---|---|---|---|---|---|---|---|---|---|"]
        for m in data["scale"]:
            before = f"{m['before_report_mb']:.0f} MB" if "before_report_mb" in m else "—"
            lines.append(f"| {m['kind']} | {m['runs']} | {shown(m['wall_s'])} | {m['runs'] / m['wall_s']:.0f} | {before} | "
                         f"{m['peak_rss_mb']:.0f} MB | {m['files']} ({m['parts']}) | {m['machine']} | {m['date']} | "
                         f"{m['load_before']:.1f}-{m['load_after']:.1f} |")
    return "\n".join(lines) + "\n"


def figure(key: str, data: dict) -> str | None:
    """What a marker of key shows (None: not measured)."""
    if key == "install_size":
        return f"{data['install']['venv_bytes'] / 1e9:.1f} GB" if "install" in data else None
    return shown(data[key]["seconds"]) if key in data else None


def when(key: str, data: dict) -> str | None:
    """Where a figure comes from: its date, machine and load average."""
    if key not in data:
        return None
    d = data[key]
    return f"{d['date']}, {d['machine'].split(', Linux')[0]}, load average {d['load']:.1f}"


def rewrite_markers(data: dict) -> list[Path]:
    changed = []
    for page in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
        text = page.read_text()
        new = MARKER.sub(lambda m: f"<!-- timing:{m[1]} -->{figure(m[1], data) or m[2]}<!-- /timing -->", text)
        new = WHEN.sub(lambda m: f"<!-- when:{m[1]} -->{when(m[1], data) or m[2]}<!-- /when -->", new)
        if new != text:
            page.write_text(new)
            changed.append(page)
    return changed


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    ap.add_argument("--only", nargs="*", default=list(KEYS), choices=KEYS)
    ap.add_argument("--write", action="store_true", help="store in docs/timings.json, regenerate docs/timings.md and the markers")
    args = ap.parse_args()
    data = json.loads(TIMINGS.read_text()) if TIMINGS.exists() else {}
    for key in args.only:
        with tempfile.TemporaryDirectory(prefix="tiltload_timing_") as tmp:
            before = load()
            result = measure(key, Path(tmp))
        result.update(machine=machine(), date=datetime.date.today().isoformat(), load=max(before, load()))
        print(f"{key}: {shown(result['seconds'])} (load average {result['load']:.1f})", flush=True)
        data[key] = result
        if args.write:  # after each figure: a long run cut short keeps what it measured
            TIMINGS.write_text(json.dumps(data, indent=1) + "\n")
            PAGE.write_text(render(data))
            for page in rewrite_markers(data):
                print(f"updated {page.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

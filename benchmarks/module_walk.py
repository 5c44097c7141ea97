"""Issue 61's "follow the data through the calls": which of tiltload's modules a `tiltload run` and one falsification
evaluation pass through, and how often the walk comes back to a folder it had left.

A profile hook (sys.setprofile) records every Python call whose function lives in a tiltload module; consecutive calls
in one module count once. Printed per walk: the modules entered, the folders (packages) entered, and for each folder
the number of times the walk came back to it after leaving it (a "climb back"). Run it with each tree's interpreter
to compare two trees the same way:

    python benchmarks/module_walk.py [--fmus DIR] [--json OUT]

The run: `tiltload run --scenario fsi --stop-time 1 --no-plots` through the command line's entry point, in process.
The evaluation: one point of docs/falsification/swing_gust.toml (the gust searched at the middle of its ranges), on a
worker state of its own, in process (the Dask dispatch around it is not tiltload's code).
"""

from __future__ import annotations

import argparse
import importlib
import json
import sys
import tempfile
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


class Walk:
    """The sequence of tiltload modules entered, consecutive repeats folded."""

    def __init__(self) -> None:
        self.modules: list[str] = []

    def hook(self, frame, event, arg):
        if event != "call":
            return
        name = frame.f_globals.get("__name__", "")
        if name.startswith("tiltload.") and (not self.modules or self.modules[-1] != name):
            self.modules.append(name)

    def __enter__(self):
        sys.setprofile(self.hook)
        return self

    def __exit__(self, *exc):
        sys.setprofile(None)


def summary(modules: list[str]) -> dict:
    """Distinct modules and folders, and how often each folder is entered again after the walk left it."""
    folders = [m.rpartition(".")[0] for m in modules]
    entries = Counter()
    previous = None
    for folder in folders:
        if folder != previous:
            entries[folder] += 1
        previous = folder
    returns = {f: n - 1 for f, n in entries.items() if n > 1}
    return {"modules": len(set(modules)), "folders": len(entries), "returns": sum(returns.values()),
            "returns_by_folder": dict(sorted(returns.items(), key=lambda kv: -kv[1])), "module_list": sorted(set(modules))}


def walk_run(fmus: Path) -> list[str]:
    from tiltload.master.app import cli

    with tempfile.TemporaryDirectory() as out, Walk() as walk:
        try:
            cli.entry(["run", "--scenario", "fsi", "--stop-time", "1", "--no-plots", "--quiet", "--fmus", str(fmus),
                       "--out", out])
        except SystemExit as done:
            if done.code not in (0, None):
                raise RuntimeError(f"tiltload run exited {done.code}") from None
    return walk.modules


def _first(*names: str):
    """The first of these module paths that exists in this tree (the walk measures trees before and after a move)."""
    for name in names:
        try:
            return importlib.import_module(name)
        except ModuleNotFoundError:
            continue
    raise ModuleNotFoundError(names[0])


def walk_evaluation(fmus: Path) -> list[str]:
    spec_module = _first("tiltload.master.app.falsify.spec")
    runner = _first("tiltload.master.app.falsify.runner")
    evaluate = _first("tiltload.master.app.falsify.evaluate")
    worker_module = _first("tiltload.master.app.batch.worker", "tiltload.master.app.batch.worker")
    spec = spec_module.load(ROOT / "docs" / "falsification" / "swing_gust.toml")
    base = spec.base()
    values = {d.name: (d.low + d.high) / 2 for d in spec.dimensions}
    case = runner.make_case(base)("walk", values)
    worker = worker_module.CaseWorker(keep=False)
    evaluate.evaluate(base, case, str(fmus.resolve()), worker)  # a first one builds what is lazily built
    with Walk() as walk:
        outcome = evaluate.evaluate(base, case, str(fmus.resolve()), worker)
    if "row" not in outcome:
        raise RuntimeError(f"the evaluation failed: {outcome}")
    return walk.modules


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fmus", type=Path, default=ROOT / "fmus")
    parser.add_argument("--json", type=Path, help="write the walks here too")
    args = parser.parse_args()
    from tiltload.master.app.loop.fmus import build_all

    build_all(args.fmus, progress=lambda m: None)
    walk_run(args.fmus)  # a first run compiles and caches what later runs take ready
    found = {"tiltload run": summary(walk_run(args.fmus)), "one falsification evaluation": summary(walk_evaluation(args.fmus))}
    for what, s in found.items():
        print(f"{what}: {s['modules']} modules in {s['folders']} folders, {s['returns']} returns to a folder left")
        for folder, n in s["returns_by_folder"].items():
            print(f"    {folder.removeprefix('tiltload.')}: back {n}x")
    if args.json:
        args.json.write_text(json.dumps(found, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

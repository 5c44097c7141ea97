"""Issue 61's "follow the data through the calls": which of tiltload's modules a `tiltload run` and one falsification
evaluation pass through, and how often the walk comes back to a folder it had left.

A profile hook (sys.setprofile) records every Python call whose function lives in a tiltload module. Printed per walk:
the modules entered, their folders (packages), and for each folder how often the walk entered it again from outside
it (a call whose caller lives in another folder; a folder's own modules calling each other do not count).
Run it with each tree's interpreter to compare two trees the same way:

    python benchmarks/module_walk.py [--fmus DIR] [--json OUT]

The run: `tiltload run --scenario fsi --stop-time 1 --no-plots` through the command line's main(), in process.
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
    """The calls into tiltload's modules: each module entered, and each entry into a folder from another folder (a
    call whose caller lives outside the callee's folder: a folder's own helpers calling each other do not count)."""

    def __init__(self) -> None:
        self.modules: set[str] = set()
        self.entries: list[str] = []  # the folder entered, once per call from outside it

    def hook(self, frame, event, arg):
        if event != "call":
            return
        name = frame.f_globals.get("__name__", "")
        if not name.startswith("tiltload."):
            return
        self.modules.add(name)
        caller = frame.f_back.f_globals.get("__name__", "") if frame.f_back is not None else ""
        folder = name.rpartition(".")[0]
        if caller.rpartition(".")[0] != folder:
            self.entries.append(folder)

    def __enter__(self):
        sys.setprofile(self.hook)
        return self

    def __exit__(self, *exc):
        sys.setprofile(None)


def summary(walk: Walk) -> dict:
    """Distinct modules and folders, and how often the walk enters each folder again from outside it."""
    entries = Counter(walk.entries)
    returns = {f: n - 1 for f, n in entries.items() if n > 1}
    return {"modules": len(walk.modules), "folders": len({m.rpartition(".")[0] for m in walk.modules}),
            "returns": sum(returns.values()), "returns_by_folder": dict(sorted(returns.items(), key=lambda kv: -kv[1])),
            "module_list": sorted(walk.modules)}


def walk_run(fmus: Path) -> Walk:
    from tiltload.master.app import cli

    with tempfile.TemporaryDirectory() as out, Walk() as walk:
        code = cli.main(["run", "--scenario", "fsi", "--stop-time", "1", "--no-plots", "--quiet", "--fmus", str(fmus),
                         "--out", out])
    if code != 0:
        raise RuntimeError(f"tiltload run exited {code}")
    return walk


def _first(*names: str):
    """The first of these module paths that exists in this tree (the walk measures trees before and after a move)."""
    for name in names:
        try:
            return importlib.import_module(name)
        except ModuleNotFoundError:
            continue
    raise ModuleNotFoundError(names[0])


def walk_evaluation(fmus: Path) -> Walk:
    spec_module = _first("tiltload.master.app.falsify.spec")
    runner = _first("tiltload.master.app.falsify.runner")
    evaluate = _first("tiltload.master.app.falsify.evaluate")
    worker_module = _first("tiltload.master.app.batch.worker", "tiltload.master.app.campaign" ".worker")  # (5052690: campaign/)
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
    return walk


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    parser.add_argument("--fmus", type=Path, default=ROOT / "fmus")
    parser.add_argument("--json", type=Path, help="write the walks here too")
    args = parser.parse_args()
    build_all = _first("tiltload.master.app.loop.fmus", "tiltload.master.app" ".fmus").build_all

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

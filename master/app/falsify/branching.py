"""Branching from a snapshot: where every searched input acts only after a time, each worker runs the prefix once and
every evaluation goes on from its snapshot (evaluate.py). Whether that beats re-running the prefix is measured, not
assumed (docs/falsification.md, "Cheaper evaluations"): `choose` runs the spec's midpoint both ways in this process,
checks that the two give the same robustness bit for bit, and takes the one of lower CPU time (median of a few runs,
alternated, so a load that changes meanwhile falls on both).

Which inputs act late: a fault's fields (faults.N.start|end|value|duration) do nothing before the fault starts, so
the branch tick is the last one before the earliest start any fault of base.faults can have (a searched start's low
bound, else its start), one tick earlier for safety. Faults that look back in time (delay, stale, jitter: the values of
ticks before) or draw from a random stream per tick (noise) are not branched. FMU parameters, gusts (the scenario
FMU's wind profile is a fixed parameter: it cannot change in a run continued from a snapshot) and initial offsets act
from t = 0: a search over any of them runs whole runs.
"""

from __future__ import annotations

import hashlib
import json
import math
import statistics
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from .spec import BranchPoint, SearchBase

LOOKS_BACK = ("delay", "stale", "jitter", "noise")
MIN_TICKS = 16  # a prefix shorter than this (0.19 s) is not worth a snapshot


def branch_tick(dimensions, faults: list, tick: float) -> int | None:
    """The tick to branch at, or None when some searched input may act before any fault starts (module docstring)."""
    if not dimensions or not faults or any(not d.target.startswith("faults.") for d in dimensions):
        return None
    if any(f.get("action") in LOOKS_BACK for f in faults):
        return None
    earliest = math.inf
    for n, fault in enumerate(faults):
        searched = [d for d in dimensions if d.target == f"faults.{n}.start"]
        earliest = min(earliest, searched[0].low if searched else float(fault.get("start", 0.0)))
    k = math.floor(earliest / tick + 1e-9) - 1
    return k if k >= MIN_TICKS else None


def with_branch(base: SearchBase, ticks: int) -> SearchBase:
    """base with its branch point (the key tells workers' snapshots of different bases apart)."""
    what = json.dumps({k: getattr(base, k) for k in ("scenario", "stop_time", "gusts", "faults", "parameters", "controller",
                                                     "seed", "signals")} | {"trajectory": str(base.trajectory), "ticks": ticks},
                      sort_keys=True, default=str)
    return replace(base, branch=BranchPoint(ticks, hashlib.sha256(what.encode()).hexdigest()[:16]))


def choose(base: SearchBase, dimensions, fmus: Path, ticks: int, repeat: int = 9) -> tuple[bool, str]:
    """Measure whole runs against branches on the spec's midpoint and a corner: (branch?, the line that says why)."""
    from ..batch.worker import CaseWorker
    from .evaluate import evaluate
    from .space import case_parameters, values_at

    worker = CaseWorker()  # this process's executions and snapshot for the calibration, closed after it
    try:
        branched = with_branch(base, ticks)
        cases = []
        for u in (0.5, 0.0):
            values = values_at(dimensions, np.full(len(dimensions), u))
            cases.append({"run_id": f"calibrate-{u}", "values": values, "parameters": case_parameters(base, values)})
        for case in cases:  # the same outcome both ways (and the executions, the snapshot made: not timed)
            whole, branch = evaluate(base, case, str(fmus), worker).get("row"), evaluate(branched, case, str(fmus), worker).get("row")
            if whole is None or branch is None:  # an environment's failure (say, an FMU that cannot serialize its state)
                return False, "branching from a snapshot: not used (the calibration could not run it here)"
            same = whole["robustness"] == branch["robustness"] or (math.isnan(whole["robustness"])
                                                                   and math.isnan(branch["robustness"]))
            if not same:
                return False, (f"branching from a snapshot: not used (its robustness {branch['robustness']!r} differs from the "
                               f"whole run's {whole['robustness']!r})")
        spent: dict[str, list[float]] = {"whole": [], "branch": []}
        for _ in range(repeat):
            for label, b in (("whole", base), ("branch", branched)):
                started = time.process_time()
                evaluate(b, cases[0], str(fmus), worker)
                spent[label].append(time.process_time() - started)
    finally:
        worker.close()
    whole, branch = statistics.median(spent["whole"]), statistics.median(spent["branch"])
    use = branch < whole
    from ..loop.thesis import TICK

    return use, (f"branching from a snapshot at t = {ticks * TICK:.3f} s: {branch * 1e3:.2f} ms against {whole * 1e3:.2f} ms "
                 f"for the whole run (CPU, median of {repeat}): {'used' if use else 'not used'}")

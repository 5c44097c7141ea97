"""One campaign run, as a Dask worker executes it: the case's system (case/system.py) run through the engine's one life
cycle (engine/lifecycle.py) on the worker's execution pool (batch/worker.py), its metrics (metrics.py) and its row."""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

from ...engine.errors import DescriptionError
from ...engine.lifecycle import RunPlan, run_plan
from ...engine.log.logger import McapLogger
from ...engine.requirement.observer import RequirementObserver
from ..batch.worker import RUN_FAILURES, CaseWorker, MissingFmu, environment_failure, this_worker
from ..case.flight import flight_of, stop_of
from ..case.system import branch_system, case_system
from ..case.verdict_counts import ERROR
from ..loop.fmus import is_foreign
from ..loop.scene import scene_channels
from ..loop.thesis import PLANT
from .metrics import CampaignMetrics
from .spec import CampaignBase


def error_row(case: dict, error: str, requirements: tuple = ()) -> dict:
    """The row of a run that produced no metrics: each requirement ERROR (it judged nothing)."""
    controller = case["controller"] if case["controller"] in ("dlqr", "mixed") else Path(case["controller"]).stem
    return {"run_id": case["run_id"], "controller": controller, "seed": case["seed"], **case["values"], "completed": False,
            "diverged": False, "diverged_at": math.nan, "error": error,
            **{k: v for name, _ in requirements for k, v in _judged(name, ERROR, None)}}


def _judged(name: str, verdict: str, result) -> tuple:
    """A requirement's columns: NAME_verdict, NAME_robustness (NaN: undecided), and for a FAIL NAME_first_violation (s,
    else NaN) and NAME_values (the signals there, JSON; "{}" else), which the report's FAIL rows show."""
    decided = result is not None and result.robustness is not None and verdict != ERROR
    failed = result is not None and result.first_violation is not None and verdict != ERROR
    values = {k: float(v) for k, v in result.values.items()} if failed else {}
    return ((f"{name}_verdict", verdict), (f"{name}_robustness", result.robustness if decided else math.nan),
            (f"{name}_first_violation", result.first_violation if failed else math.nan), (f"{name}_values", json.dumps(values)))


def run_case(base: CampaignBase, case: dict, fmu_dir: str, log_dir: str | None, snapshot: bytes | None = None,
             worker: CaseWorker | None = None) -> dict:
    """Run one case (with snapshot, the bytes of a snapshot file: from there) on the worker's executions (None: this
    Dask worker's, worker.this_worker). Its outcome: {"row", "wall", "setup", "sim_time"}, the row holding the metrics
    or the run's error line; or, when its environment failed, {"environment": the line, "worker": the worker's
    address}. Never raises."""
    try:
        worker = worker if worker is not None else this_worker()
        if snapshot is not None:
            return _run_branch(worker, base, case, fmu_dir, log_dir, snapshot)
        return _run_case(worker, base, case, fmu_dir, log_dir)
    except Exception as err:  # not the run's outcome: retried, never stored
        return environment_failure(err)


def _run_branch(worker: CaseWorker, base: CampaignBase, case: dict, fmu_dir: str, log_dir: str | None, data: bytes) -> dict:
    started = time.perf_counter()
    _, snap = worker.snapshot(data)
    system, snap = branch_system(Path(fmu_dir), snap, base.faults, case["parameters"], case["controller"])
    worker.check_fmus(system)
    metrics = CampaignMetrics(bounds=base.scenario == "zse", settle=snap.time)  # the branch's own: from the snapshot
    observers = [metrics, *_monitor(base)]
    if log_dir:
        observers.insert(0, McapLogger(Path(log_dir) / f"{case['run_id']}.mcap", derived=scene_channels(PLANT),
                                       metadata={"run_id": case["run_id"], "from_snapshot": f"t = {snap.time:.3f} s",
                                                 **{k: str(v) for k, v in case["parameters"].items()}}))
    return _execute(worker, system, observers, metrics, base, case, started, snap)


def _monitor(base: CampaignBase) -> list:
    """The requirements' observer of keep.requirements (a fresh one a run), or none."""
    if not base.requirements:
        return []
    from ...engine.requirement.files import requirement

    return [RequirementObserver([requirement(name, text) for name, text in base.requirements])]


def _run_case(worker: CaseWorker, base: CampaignBase, case: dict, fmu_dir: str, log_dir: str | None) -> dict:
    started = time.perf_counter()
    worker.verdicts.update(base.feasibility)  # the client's verdicts (worker.feasibility_verdicts)
    if case["controller"] not in ("dlqr", "mixed") and not Path(case["controller"]).is_file():
        raise MissingFmu(f"no controller FMU at {case['controller']}")  # read while the system is described
    try:
        system = case_system(Path(fmu_dir), base, case["controller"], case["seed"], case["parameters"])
    except DescriptionError as err:  # the case's own (its controller file is not an FMU, or not one of a tick's period)
        return {"row": error_row(case, str(err), base.requirements), "wall": time.perf_counter() - started, "setup": 0.0, "sim_time": 0.0}
    worker.check_fmus(system)
    stop = stop_of(base)
    refused = worker.infeasible(system, stop, flight_of(base))
    if refused:  # before the first step, as tiltload run refuses it
        return {"row": error_row(case, refused, base.requirements), "wall": time.perf_counter() - started, "setup": 0.0, "sim_time": 0.0}
    metrics = CampaignMetrics(bounds=base.scenario == "zse", settle=min(5.0, stop / 2))
    observers = [metrics, *_monitor(base)]
    if log_dir:
        observers.insert(0, McapLogger(Path(log_dir) / f"{case['run_id']}.mcap", derived=scene_channels(PLANT),
                                       metadata={"run_id": case["run_id"], **case["parameters"]}))
    return _execute(worker, system, observers, metrics, base, case, started)


def _execute(worker: CaseWorker, system, observers, metrics, base, case, started, resume=None) -> dict:
    """Run the case on the worker's pool (its execution of this structure restarted, or a new one); its outcome."""
    plan = RunPlan(system, stop_of(base), observers=tuple(observers), isolate=is_foreign, resume=resume,
                   outcomes=RUN_FAILURES, when=False)
    before = time.perf_counter() - started
    try:
        result = run_plan(plan, worker.pool)
    except RUN_FAILURES as err:  # the system refused before anything loaded (a value, the snapshot): the row says why
        error, sim_time, setup = str(err), 0.0, time.perf_counter() - started
    else:
        error, sim_time, setup = result.error, result.sim_time, before + result.setup
    diverged = error is not None and ("diverged" in error or "non-finite" in error)
    row = {"run_id": case["run_id"], "controller": Path(case["controller"]).stem if case["controller"] not in ("dlqr", "mixed")
           else case["controller"], "seed": case["seed"], **case["values"],
           **metrics.row(base.keep_metrics), "completed": error is None, "diverged": diverged,
           "diverged_at": sim_time if diverged else math.nan, "error": error or ""}
    for obs in observers:
        if isinstance(obs, RequirementObserver):  # NAME_verdict, NAME_robustness (NaN: undecided)
            results = {r.name: r for r in obs.results}
            for name, _ in base.requirements:
                r = results.get(name)  # a failed or diverged run judged nothing: ERROR, not the FAIL of its NaN
                row.update(_judged(name, ERROR if error else r.shown if r is not None else "INCONCLUSIVE", r))  # "PASS (vacuous)" too
    return {"row": row, "wall": time.perf_counter() - started, "setup": setup, "sim_time": sim_time}

"""One evaluation: the loop run as a campaign case runs (case/system.py: its system; batch/worker.py: its
feasibility check and the worker's executions; run through engine/lifecycle.py), the requirements' signals kept by an
observer, each requirement's robustness.

Why an observer and not a log read back: it keeps a few columns of the tick loop's batches, where the log encodes every
output of every FMU and the reader decodes them again (benchmarks/falsification.py measures both, side by side).

The objective is the lowest robustness over the requirements (the conjunction's). A run the loop ends early (diverged,
an FMU's error) is judged on what it got: its robustness is the highest any continuation could give (the STL
library's upper bound), negative only when every continuation violates; a case the feasibility check refuses has none.

Cheaper evaluations (docs/falsification.md, "Cheaper evaluations"):
- early stop (base.early_stop): the run stops at the first check (every signals.CHECK_TICKS ticks) where a
  requirement's FAIL is decided; its robustness is then the upper bound over every continuation of the trace so far
  (for always[a:b] p: the lowest margin of p so far), which is below 0 and at least the whole run's robustness. A run
  that does not fail runs to its end: its robustness is exact. So the sign, and the order of every passing run, are
  those of whole runs; rows say `stopped_at`.
- branching (base.branch): when every searched input acts only after a tick k0 (faults that start later), each
  worker runs the base case to k0 once, keeps a snapshot (master/engine/snapshot.py) and runs every evaluation from
  it with the case's faults; the recorder's records up to k0 come with the snapshot, so the trace is the whole run's.
"""

from __future__ import annotations

import dataclasses
import math
import socket
import time
from pathlib import Path

from ....scenario_fmu.files import ScenarioFileError
from ...engine.lifecycle import RunPlan, run_plan
from ...engine.observers import StopRun
from ...engine.requirement.stl import Evaluator, verdict
from ..batch.worker import RUN_FAILURES, CaseWorker, environment_failure, this_worker, worker_address
from ..case.system import case_system
from ..loop.fmus import is_foreign
from .signals import CHECK_TICKS, SignalRecorder
from .space import case_flight
from .spec import SearchBase


def robustness(formulas: list[str], trace, final: bool, worker: CaseWorker | None = None) -> tuple[list[float], list[str]]:
    """Each formula's robustness at the trace's start (decided: its value; else the upper bound) and verdict (the
    formulas parsed once by the worker given)."""
    worker = worker if worker is not None else CaseWorker(keep=False)
    rho, verdicts = [], []
    ev = Evaluator(trace, final)  # shared: a signal's nodes are evaluated once for all formulas
    for text in formulas:
        v = verdict(worker.formula(text), trace, final, ev)
        rho.append(v.robustness if v.robustness is not None else v.bounds[1])
        verdicts.append(v.shown)  # "PASS (vacuous)": its trigger never held (docs/requirements.md, Vacuity)
    return rho, verdicts


def _branch_point(worker: CaseWorker, base: SearchBase, fmu_dir: Path):
    """The snapshot of the base case at tick k0, made once by this worker (its execution goes back to the pool)."""
    from ...engine import snapshot

    key = ("branch", base.branch.key, str(fmu_dir))
    if key in worker.branch_points:
        return worker.branch_points[key]
    system = case_system(fmu_dir, base, base.controller, base.seed, base.parameters)
    worker.check_fmus(system)
    taken = []
    at = base.branch.ticks * system.tick
    plan = RunPlan(system, at, observers=(SignalRecorder(base.signals),), isolate=is_foreign,
                   checkpoints=((at, lambda execution: taken.append(snapshot.take(execution))),), outcomes=())
    run_plan(plan, worker.pool)
    worker.branch_points.clear()  # one base at a time per worker
    worker.branch_points[key] = taken[0]
    return taken[0]


def run_loop(base: SearchBase, parameters: dict, fmu_dir: Path, observers: list, branch: bool = False,
             worker: CaseWorker | None = None) -> tuple[str | None, float, str | None, bool]:
    """Run the loop of a case once on the worker's executions: (refused: the feasibility check's line, sim_time
    reached, error line, stopped early by an observer). branch: from the worker's snapshot of the base case
    (base.branch). The same FMUs whatever the reference (a moved mission too): a restart sets every parameter.
    worker: whose executions (None: an execution for this run only)."""
    worker = worker if worker is not None else CaseWorker(keep=False)
    system = case_system(fmu_dir, base, base.controller, base.seed, parameters)
    worker.check_fmus(system)
    refused = worker.infeasible(system, base.stop_time, base.trajectory)
    if refused:
        return refused, 0.0, None, False
    segmented = any(getattr(o, "stop_on", None) for o in observers)
    plan = RunPlan(system, base.stop_time, observers=tuple(observers), isolate=is_foreign,
                   resume=_branch_point(worker, base, fmu_dir) if branch else None, segment=CHECK_TICKS if segmented else None,
                   outcomes=(*RUN_FAILURES, StopRun), when=False)
    result = run_plan(plan, worker.pool)
    stopped = isinstance(result.failure, StopRun)  # an observer decided the outcome (a requirement's FAIL): done
    return None, float(result.sim_time), None if stopped else result.error, stopped


def evaluate(base: SearchBase, case: dict, fmu_dir: str, worker: CaseWorker | None = None) -> dict:
    """The outcome of one point, as batch/dispatch.py expects it: {"row", "wall", "setup", "sim_time"}; or, when its
    environment failed (not the run), {"environment": line, "worker": address}. Never raises. worker: whose executions
    (None: this Dask worker's, campaign/worker.this_worker)."""
    started, cpu = time.perf_counter(), time.thread_time()
    try:
        worker = worker if worker is not None else this_worker()
        if case.get("controller", base.controller) != base.controller:  # this worker's copy of a shipped controller FMU
            base = dataclasses.replace(base, controller=case["controller"])  # (batch/shipping.py)
        early = base.early_stop
        recorder = SignalRecorder(base.signals, [worker.formula(f) for f in base.requirements] if early else None)
        try:
            run_base, parameters = case_flight(base, case["parameters"])
        except ScenarioFileError as err:  # the moved mission is no mission (waypoints out of order): the case's own
            refused, sim_time, error, stopped = f"the moved mission: {err}", 0.0, None, False
        else:
            refused, sim_time, error, stopped = run_loop(run_base, parameters, Path(fmu_dir), [recorder],
                                                         branch=base.branch is not None, worker=worker)
        row = {"run_id": case["run_id"], **case["values"], "completed": refused is None and error is None and not stopped,
               "error": refused or error or "", "sim_time": sim_time, "worker": worker_address() or socket.gethostname(),
               "stopped_at": recorder.stopped_at if stopped else math.nan}
        names = base.requirement_names or [f"r{i}" for i in range(len(base.requirements))]
        if refused is None and recorder.started:
            trace = recorder.trace(common=True) if stopped else recorder.trace()  # stopped: the exact prefix it judged
            rho, verdicts = robustness(base.requirements, trace, error is None and not stopped, worker)
        else:  # refused, or failed before its start (a controller whose instantiation raised): its line is the outcome
            rho, verdicts = [math.nan] * len(names), ["REFUSED" if refused else "ERROR"] * len(names)
        for name, r, v in zip(names, rho, verdicts):
            row[f"rho_{name}"] = float(r)
            row[f"verdict_{name}"] = v
        row["robustness"] = float(min(rho)) if refused is None else math.nan
        wall = time.perf_counter() - started
        row["wall_s"] = wall
        row["cpu_s"] = time.thread_time() - cpu  # this thread's: the run and its robustness, not the worker's other work
        return {"row": row, "wall": wall, "setup": 0.0, "sim_time": sim_time}
    except Exception as err:  # the environment's failure: retried elsewhere by the dispatcher, never stored
        return environment_failure(err)

"""One evaluation: the loop run as a campaign case runs (campaign/run_case.py: its system, its feasibility check, its
reused execution per worker), the requirements' signals kept by an observer, each requirement's robustness.

Why an observer and not a log read back: it keeps a few columns of the tick loop's batches, where the log encodes every
output of every FMU and the reader decodes them again (benchmarks/falsification.py measures both, side by side).

The objective is the lowest robustness over the requirements (the conjunction's). A run the loop ends early (diverged,
an FMU's error) is judged on what it got: its robustness is the highest any continuation could give (the STL
library's upper bound), negative only when every continuation violates; a case the feasibility check refuses has none.

Cheaper evaluations (docs/falsification.md, "Cheaper evaluations"):
- early stop (base["early_stop"]): the run stops at the first check (every signals.CHECK_TICKS ticks) where a
  requirement's FAIL is decided; its robustness is then the upper bound over every continuation of the trace so far
  (for always[a:b] p: the lowest margin of p so far), which is below 0 and at least the whole run's robustness. A run
  that does not fail runs to its end: its robustness is exact. So the sign, and the order of every passing run, are
  those of whole runs; rows say `stopped_at`.
- branching (base["branch"]): when every searched input acts only after a tick k0 (faults that start later), each
  worker runs the base case to k0 once, keeps a snapshot (master/engine/snapshot.py) and runs every evaluation from
  it with the case's faults; the recorder's records up to k0 come with the snapshot, so the trace is the whole run's.
"""

from __future__ import annotations

import math
import socket
import time
from pathlib import Path

from ....scenario_fmu.files import ScenarioFileError
from ...engine.execution import Execution
from ...engine.observers import StopRun
from ...engine.stl import Evaluator, parse, verdict
from ..campaign.run_case import RUN_FAILURES, case_system, check_fmus, environment_failure, infeasible, worker_address
from ..fmus import is_foreign
from .signals import CHECK_TICKS, SignalRecorder
from .space import case_flight

_EXECUTIONS: dict[tuple, Execution] = {}  # per worker process: one execution per loop structure, restarted per run
_BRANCHES: dict[tuple, tuple] = {}  # per worker process: (execution, snapshot at k0) per branching base
_FORMULAS: dict[str, object] = {}


def _formula(text: str):
    if text not in _FORMULAS:
        _FORMULAS[text] = parse(text)
    return _FORMULAS[text]


def robustness(formulas: list[str], trace, final: bool) -> tuple[list[float], list[str]]:
    """Each formula's robustness at the trace's start (decided: its value; else the upper bound) and verdict."""
    rho, verdicts = [], []
    ev = Evaluator(trace, final)  # shared: a signal's nodes are evaluated once for all formulas
    for text in formulas:
        v = verdict(_formula(text), trace, final, ev)
        rho.append(v.robustness if v.robustness is not None else v.bounds[1])
        verdicts.append(v.verdict)
    return rho, verdicts


def advance(execution: Execution, stop: float, segmented: bool) -> None:
    """Run to the stop time; segmented: in calls that end on whole multiples of CHECK_TICKS (the early-stop checks)."""
    tick = execution.system.tick
    n = int(round(stop / tick))
    if not segmented:
        execution.run(stop)
        return
    while execution.ticks_done < n:
        execution.run(min(n, (execution.ticks_done // CHECK_TICKS + 1) * CHECK_TICKS) * tick)


def _branch_point(base: dict, fmu_dir: Path, key: tuple):
    """This worker's execution at the snapshot of the base case at tick k0 (made once)."""
    from ...engine import snapshot

    got = _BRANCHES.get(key)
    if got is not None and not any(i.fatal for i in got[0].instances.values()):
        return got
    if got is not None:
        got[0].close()
    system = case_system(fmu_dir, base, base["controller"], base["seed"], base["parameters"])
    check_fmus(system)
    recorder = SignalRecorder(base["signals"])
    execution = Execution(system, [recorder], isolate=is_foreign)
    execution.instantiate()
    execution.run(base["branch"]["ticks"] * system.tick)
    snap = snapshot.take(execution)
    _BRANCHES.clear()  # one base at a time per worker
    _BRANCHES[key] = (execution, snap)
    return execution, snap


def run_loop(base: dict, parameters: dict, fmu_dir: Path, observers: list,
             branch: bool = False) -> tuple[str | None, float, str | None, bool]:
    """Run the loop of a case once: (refused: the feasibility check's line, sim_time reached, error line, stopped early
    by an observer). branch: from the worker's snapshot of the base case (base["branch"])."""
    system = case_system(fmu_dir, base, base["controller"], base["seed"], parameters)
    check_fmus(system)
    refused = infeasible(system, base["stop_time"], base["trajectory"])
    if refused:
        return refused, 0.0, None, False
    segmented = any(getattr(o, "stop_on", None) for o in observers)
    if branch:
        key = ("branch", base["branch"]["key"], str(fmu_dir))
        execution, snap = _branch_point(base, fmu_dir, key)
        _BRANCHES.pop(key)
    else:
        # the same FMUs whatever the reference (a moved mission too): restart sets every parameter
        key = ("falsify", base["scenario"], str(base["trajectory"]), base["gusts"], base["controller"], str(fmu_dir))
        execution = _EXECUTIONS.pop(key, None)
    error, healthy, stopped = None, False, False
    try:
        if branch:
            execution.restart(None, observers, system.faults, resume=snap)
        elif execution is None:
            execution = Execution(system, observers, isolate=is_foreign)
            execution.instantiate()
        else:
            execution.restart({i.name: i.parameters for i in system.instances}, observers, system.faults)
        advance(execution, base["stop_time"], segmented)
        healthy = True
    except StopRun:  # an observer decided the outcome (a requirement's FAIL): the run is done
        healthy = stopped = True
    except RUN_FAILURES as err:
        error, healthy = str(err), True
    finally:
        if execution is not None:
            for obs in execution.observers:
                obs.finish(execution, error)
            execution.observers = []
            if not healthy or any(i.fatal for i in execution.instances.values()):
                execution.close()
            elif branch:
                _BRANCHES[key] = (execution, snap)
            else:
                _EXECUTIONS[key] = execution
    return None, float(execution.time) if execution is not None else 0.0, error, stopped


def evaluate(base: dict, case: dict, fmu_dir: str) -> dict:
    """The outcome of one point, as campaign/dispatch.py expects it: {"row", "wall", "setup", "sim_time"}; or, when its
    environment failed (not the run), {"environment": line, "worker": address}. Never raises."""
    started, cpu = time.perf_counter(), time.thread_time()
    try:
        early = base.get("early_stop", False)
        recorder = SignalRecorder(base["signals"], [_formula(f) for f in base["requirements"]] if early else None)
        try:
            run_base, parameters = case_flight(base, case["parameters"])
        except ScenarioFileError as err:  # the moved mission is no mission (waypoints out of order): the case's own
            refused, sim_time, error, stopped = f"the moved mission: {err}", 0.0, None, False
        else:
            refused, sim_time, error, stopped = run_loop(run_base, parameters, Path(fmu_dir), [recorder],
                                                         branch=base.get("branch") is not None)
        row = {"run_id": case["run_id"], **case["values"], "completed": refused is None and error is None and not stopped,
               "error": refused or error or "", "sim_time": sim_time, "worker": worker_address() or socket.gethostname(),
               "stopped_at": recorder.stopped_at if stopped else math.nan}
        names = base.get("requirement_names") or [f"r{i}" for i in range(len(base["requirements"]))]
        if refused is None and recorder.started:
            trace = recorder.trace(common=True) if stopped else recorder.trace()  # stopped: the exact prefix it judged
            rho, verdicts = robustness(base["requirements"], trace, error is None and not stopped)
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

"""One evaluation: the loop run as a campaign case runs (campaign/run_case.py: its system, its feasibility check, its
reused execution per worker), the requirements' signals kept by an observer, each requirement's robustness.

Why an observer and not a log read back: it keeps a few columns of the tick loop's batches, where the log encodes every
output of every FMU and the reader decodes them again (benchmarks/falsification.py measures both, side by side).

The objective is the lowest robustness over the requirements (the conjunction's). A run the loop ends early (diverged,
an FMU's error) is judged on what it got: its robustness is the highest any continuation could give (the STL
library's upper bound), negative only when every continuation violates; a case the feasibility check refuses has none.
"""

from __future__ import annotations

import math
import socket
import time
from pathlib import Path

from ...engine.execution import Execution
from ...engine.stl import Evaluator, parse, verdict
from ..campaign.run_case import RUN_FAILURES, case_system, check_fmus, environment_failure, infeasible, worker_address
from ..fmus import is_foreign
from .signals import SignalRecorder

_EXECUTIONS: dict[tuple, Execution] = {}  # per worker process: one execution per loop structure, restarted per run
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


def run_loop(base: dict, parameters: dict, fmu_dir: Path, observers: list) -> tuple[str | None, float, str | None]:
    """Run the loop of a case once: (refused: the feasibility check's line, sim_time reached, error line)."""
    system = case_system(fmu_dir, base, base["controller"], base["seed"], parameters)
    check_fmus(system)
    refused = infeasible(system, base["stop_time"], base["trajectory"])
    if refused:
        return refused, 0.0, None
    key = ("falsify", base["scenario"], base["trajectory"], base["gusts"], base["controller"], str(fmu_dir))
    execution = _EXECUTIONS.pop(key, None)
    error, healthy = None, False
    try:
        if execution is None:
            execution = Execution(system, observers, isolate=is_foreign)
            execution.instantiate()
        else:
            execution.restart({i.name: i.parameters for i in system.instances}, observers, system.faults)
        execution.run(base["stop_time"])
        healthy = True
    except RUN_FAILURES as err:
        error, healthy = str(err), True
    finally:
        if execution is not None:
            for obs in execution.observers:
                obs.finish(execution, error)
            execution.observers = []
            if not healthy or any(i.fatal for i in execution.instances.values()):
                execution.close()
            else:
                _EXECUTIONS[key] = execution
    return None, float(execution.time) if execution is not None else 0.0, error


def evaluate(base: dict, case: dict, fmu_dir: str) -> dict:
    """The outcome of one point, as campaign/dispatch.py expects it: {"row", "wall", "setup", "sim_time"}; or, when its
    environment failed (not the run), {"environment": line, "worker": address}. Never raises."""
    started = time.perf_counter()
    try:
        recorder = SignalRecorder(base["signals"])
        refused, sim_time, error = run_loop(base, case["parameters"], Path(fmu_dir), [recorder])
        row = {"run_id": case["run_id"], **case["values"], "completed": refused is None and error is None,
               "error": refused or error or "", "sim_time": sim_time, "worker": worker_address() or socket.gethostname()}
        names = base.get("requirement_names") or [f"r{i}" for i in range(len(base["requirements"]))]
        if refused is None:
            rho, verdicts = robustness(base["requirements"], recorder.trace(), error is None)
        else:
            rho, verdicts = [math.nan] * len(names), ["REFUSED"] * len(names)
        for name, r, v in zip(names, rho, verdicts):
            row[f"rho_{name}"] = float(r)
            row[f"verdict_{name}"] = v
        row["robustness"] = float(min(rho)) if refused is None else math.nan
        wall = time.perf_counter() - started
        row["wall_s"] = wall
        return {"row": row, "wall": wall, "setup": 0.0, "sim_time": sim_time}
    except Exception as err:  # the environment's failure: retried elsewhere by the dispatcher, never stored
        return environment_failure(err)

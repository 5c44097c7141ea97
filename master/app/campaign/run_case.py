"""One campaign run, as a Dask worker executes it: the tiltload loop with a case's parameters, and its row.

Each worker process keeps one execution (one set of FMU instances) per system structure and
starts every run on it with fmi2Reset (Execution.restart): cheaper than instantiating four FMUs
per run (benchmarks/campaign.py measures both).

What a run produced is its outcome, a row: completed, or failed with its one line (the engine's DescriptionError or
ExecutionError: an FMU refused a value, the loop diverged, an FMU reported an error). Anything else (an FMU file this
worker cannot see, an import error, memory, a bug) is a failure of the environment, not of the run: it comes back as
such, with the worker's address, for the campaign to try again elsewhere; it is never a row.
"""

from __future__ import annotations

import copy
import hashlib
import math
import os
import socket
import stat
import time
import zipfile
from pathlib import Path

import numpy as np

from ...engine.errors import DescriptionError, ExecutionError
from ...engine.execution import Execution
from ...engine.mcap_log import McapLogger
from ...engine.observers import Metrics, real_outputs
from ...engine.requirement_observer import RequirementObserver
from ..feasibility import check_system
from ..fmus import is_foreign
from ..loop import COMMANDS, CONTROLLER, PLANT, SCENARIO, TRACKED, default_stop, default_system
from ..scene import scene_channels
from .spec import Flight

_EXECUTIONS: dict[tuple, Execution] = {}  # per worker process: reused across runs
RUN_FAILURES = (DescriptionError, ExecutionError)  # the engine's word on the run itself: kept as its outcome


_CHECKED: dict[tuple, str | None] = {}  # per worker process: the feasibility verdict per reference and plant parameters


class MissingFmu(FileNotFoundError):
    """An FMU file of the run is not on this worker (or not a whole FMU): its environment, not the run."""


class CampaignMetrics(Metrics):
    """ISE and IADU, plus the worst tracking error (after `settle` s: the runs start 30 cm off the path), the share of
    ticks with an actuator at its limit and, in the ZSE scenario, the share of ticks with the true state in the bounds."""

    def __init__(self, limits=(0.0, 30.0, 2.0), bounds: bool = True, settle: float = 5.0) -> None:
        super().__init__(PLANT, SCENARIO, CONTROLLER, TRACKED, COMMANDS)
        self.settle = settle  # the worst tracking error counts after the initial offset is taken up
        self.limits = limits
        self.bounds = bounds  # the controller's est_*_lo/hi are an estimator's set (the ZSE scenario)
        self.max_error = 0.0
        self.saturated = 0
        self.contained = 0
        self.controller_steps = 0
        self._lo = self._hi = None  # set at start (a run that fails at initialization never starts)

    def start(self, execution) -> None:
        super().start(execution)
        plant, ctrl = self._p, self._a
        names = [v.name for v in plant.outputs["Real"]][:20]
        ctrl_names = real_outputs(ctrl)
        self._state_index = np.arange(20)
        has_bounds = self.bounds and all(f"est_{n}_lo" in ctrl_names and f"est_{n}_hi" in ctrl_names for n in names)
        self._lo = np.array([ctrl_names[f"est_{n}_lo"] for n in names]) if has_bounds else None
        self._hi = np.array([ctrl_names[f"est_{n}_hi"] for n in names]) if has_bounds else None
        self._state = plant.values["Real"][self._state_index]

    def on_batch(self, execution, batch) -> None:
        at, e, u = self._sampled(batch)
        if len(at):
            late = batch.time[at] >= self.settle
            if late.any():
                position = e[late, :3]
                self.max_error = max(self.max_error, float(np.sqrt((position * position).sum(axis=1)).max()))
            lo, hi, tau = self.limits
            eps = 1e-9
            self.saturated += int(np.count_nonzero((u[:, 0] <= lo + eps) | (u[:, 1] <= lo + eps) | (u[:, 0] >= hi - eps)
                                                   | (u[:, 1] >= hi - eps) | (np.abs(u[:, 2]) >= tau - eps)
                                                   | (np.abs(u[:, 3]) >= tau - eps)))
            if self._lo is not None:
                state = self._carried(batch, self.plant, self._state_index, self._state, at)
                v = batch.rows[self.actuators]["Real"][batch.row[at]]
                self.contained += int(np.count_nonzero(np.all((v[:, self._lo] <= state) & (state <= v[:, self._hi]), axis=1)))
            self.controller_steps += len(at)
        plant_rows = batch.rows[self.plant]["Real"]
        if len(plant_rows):
            self._state = plant_rows[-1, self._state_index]
        self._accumulate(batch, at, e, u)

    def snapshot_state(self) -> dict:
        return {**super().snapshot_state(), "max_error": self.max_error, "saturated": self.saturated,
                "contained": self.contained, "controller_steps": self.controller_steps, "state": self._state.tolist()}

    def restore_state(self, state: dict) -> None:
        super().restore_state(state)
        self.max_error, self.saturated = state["max_error"], state["saturated"]
        self.contained, self.controller_steps = state["contained"], state["controller_steps"]
        self._state = np.array(state["state"])

    def row(self, keep: tuple[str, ...]) -> dict[str, float]:
        out = {}
        if "ISE" in keep:
            out.update(self.ise)
        if "IADU" in keep:
            out.update(self.iadu)
        if "max_tracking_error" in keep:
            out["max_tracking_error"] = self.max_error
        if "time_saturated" in keep:
            out["time_saturated"] = self.saturated / max(self.controller_steps, 1)
        if "zse_containment" in keep:
            out["zse_containment"] = self.contained / self.controller_steps if self._lo is not None and self.controller_steps else math.nan
        return out


def case_system(fmu_dir: Path, base: dict, controller: str, seed: int, parameters: dict):
    import copy

    from ...engine.faults.parse import parse

    is_fmu = controller not in ("dlqr", "mixed")
    flight = _flight(base)
    system = default_system(fmu_dir, base["scenario"], flight.trajectory, "mixed" if is_fmu else controller, seed,
                            Path(controller) if is_fmu else None, gusts=base["gusts"], wind=dict(flight.wind))
    faults = copy.deepcopy(base.get("faults", []))
    for key, value in parameters.items():
        if key.startswith("faults."):
            _, index, field = key.split(".")
            faults[int(index)][field] = value
            continue
        instance, _, name = key.partition(".")
        system.instance(instance).parameters[name] = value
    system.faults = parse(faults) if faults else []
    return system


def ready() -> bool:
    """Nothing: run on each worker of a new local cluster, so that importing this module (seconds: the controller's
    design tools come with it) is part of the cluster's start, not of the first run."""
    return True


def prepare(base: dict, case: dict, fmu_dir: str) -> bool:
    """Instantiate a case's system on this worker before its runs come (the FMUs unpacked, loaded and instantiated, as
    its first run would), while the client checks the cases' feasibility: the first run then restarts it. Never
    raises (False: not prepared; the run meets the problem again and reports it)."""
    key = execution_key(base, case, fmu_dir)
    if key in _EXECUTIONS:
        return True
    execution = None
    try:
        system = case_system(Path(fmu_dir), base, case["controller"], case["seed"], case["parameters"])
        execution = Execution(system, [], isolate=is_foreign)
        execution.instantiate()
    except Exception:
        if execution is not None:
            try:
                execution.close()
            except Exception:
                pass
        return False
    _EXECUTIONS[key] = execution
    return True


def execution_key(base: dict, case: dict, fmu_dir: str) -> tuple:
    """The systems whose runs share one execution on a worker: the same structure (parameters aside)."""
    return base["scenario"], base["trajectory"], base["gusts"], case["controller"], fmu_dir


def worker_address() -> str | None:
    """The address of the Dask worker running this (None outside a worker: called directly)."""
    try:
        from distributed import get_worker

        return get_worker().address
    except (ImportError, ValueError):
        return None


def _flight(base: dict) -> Flight:
    """base["trajectory"]: the spec's Flight, or a thesis trajectory's number."""
    flight = base["trajectory"]
    if isinstance(flight, Flight):
        return flight
    from ..inputs import trajectory as as_trajectory

    return Flight(as_trajectory(flight))


def infeasible(system, stop: float, flight: Flight) -> str | None:
    """The feasibility check's first problem for this case (None: it may run), once per reference and plant."""
    key = (flight, tuple(sorted((k, repr(v)) for k, v in system.instance(PLANT).parameters.items())), stop)
    if key not in _CHECKED:
        report = check_system(system, stop, flight.max_tilt)
        _CHECKED[key] = report.problems[0] if report is not None and report.problems else None
    problem = _CHECKED[key]
    return None if problem is None or flight.allow_infeasible else f"the reference is infeasible: {problem}"


def feasibility_verdicts(base: dict, cases: list[dict], fmu_dir: str, most: int = 16) -> dict:
    """The feasibility check's verdicts (infeasible's cache) of the first case of each set of plant parameters the cases
    vary (at most `most` sets), for the client to compute once and hand to every worker in base["feasibility"]: each
    worker would otherwise check them itself (seconds each). A case this cannot describe is left to its worker, and so
    is any verdict missed here (looked up by the same key, computed where missing)."""
    stop = base["stop_time"] or default_stop(_flight(base).trajectory)
    seen: set[tuple] = set()
    for case in cases:
        plant = tuple(sorted((k, repr(v)) for k, v in case["parameters"].items() if k.startswith(f"{PLANT}.")))
        if plant in seen or len(seen) >= most:
            continue
        seen.add(plant)
        try:
            infeasible(case_system(Path(fmu_dir), base, case["controller"], case["seed"], case["parameters"]), stop, _flight(base))
        except Exception:  # noqa: BLE001  (its worker describes it, and says what is wrong)
            continue
    return dict(_CHECKED)


def error_row(case: dict, error: str) -> dict:
    """The row of a run that produced no metrics."""
    controller = case["controller"] if case["controller"] in ("dlqr", "mixed") else Path(case["controller"]).stem
    return {"run_id": case["run_id"], "controller": controller, "seed": case["seed"], **case["values"], "completed": False,
            "diverged": False, "diverged_at": math.nan, "error": error}


def run_case(base: dict, case: dict, fmu_dir: str, log_dir: str | None, snapshot: bytes | None = None) -> dict:
    """Run one case (with snapshot, the bytes of a snapshot file: from there). Its outcome: {"row", "wall", "setup",
    "sim_time"}, the row holding the metrics or the run's error line; or, when its environment failed,
    {"environment": the line, "worker": the worker's address}. Never raises."""
    try:
        if snapshot is not None:
            return _run_branch(base, case, fmu_dir, log_dir, snapshot)
        return _run_case(base, case, fmu_dir, log_dir)
    except Exception as err:  # not the run's outcome: retried, never stored
        return environment_failure(err)


def environment_failure(err: Exception) -> dict:
    """What a worker returns when its environment, not the run, failed: one line naming the worker, and its address
    (the dispatcher retries the run elsewhere and stores nothing)."""
    address = worker_address()
    where = f"worker {address} on {socket.gethostname()}" if address else socket.gethostname()
    if isinstance(err, MissingFmu):
        line = f"{err} (the workers must see the FMU folder at the same path)"
    else:
        text = str(err).strip().splitlines()
        line = f"{type(err).__name__}: {text[0]}" if text else type(err).__name__
    return {"environment": f"{where}: {line}", "worker": address}


_SNAPSHOTS: dict[str, object] = {}  # per worker process: the snapshot of each digest, read once


def branch_system(fmu_dir: Path, snap, faults, parameters: dict, controller: str):
    """The system a snapshot was taken of (its loop options, the FMUs of fmu_dir, the controller the spec names: a
    snapshot never says where a file is), with a case's faults (None: the run's own) and the snapshot's settings for
    its tunable parameters."""
    import dataclasses

    from ...engine.faults.parse import parse
    from ..loop_system import loop_system
    from ..options import snapshot_options

    opts = dataclasses.replace(snapshot_options(snap.application, "base.snapshot"), fmus=fmu_dir)
    if opts.controller_fmu is not None:
        opts = dataclasses.replace(opts, controller=controller, controller_fmu=Path(controller))
    if faults is not None:
        opts = dataclasses.replace(opts, faults=None)
    system = loop_system(opts, fmu_dir, prepared=True).system
    settings: dict[str, dict] = {}
    if faults is not None:
        faults = copy.deepcopy(faults)
    for key, value in parameters.items():
        if key.startswith("faults."):
            _, index, field = key.split(".")
            faults[int(index)][field] = value
        else:
            instance, _, name = key.partition(".")
            settings.setdefault(instance, {})[name] = value
    if faults is not None:
        system.faults = parse(faults) if faults else []
    return system, dataclasses.replace(snap, settings=settings)


def _snapshot(data: bytes):
    from ...engine import snapshot

    digest = hashlib.sha256(data).hexdigest()
    if digest not in _SNAPSHOTS:
        _SNAPSHOTS.clear()  # one campaign at a time per worker
        _SNAPSHOTS[digest] = snapshot.from_bytes(data, "base.snapshot")
    return digest, _SNAPSHOTS[digest]


def _run_branch(base: dict, case: dict, fmu_dir: str, log_dir: str | None, data: bytes) -> dict:
    started = time.perf_counter()
    digest, snap = _snapshot(data)
    system, snap = branch_system(Path(fmu_dir), snap, base["faults"], case["parameters"], case["controller"])
    check_fmus(system)
    metrics = CampaignMetrics(bounds=base["scenario"] == "zse", settle=snap.time)  # the branch's own: from the snapshot
    observers = [metrics, *_monitor(base)]
    if log_dir:
        observers.insert(0, McapLogger(Path(log_dir) / f"{case['run_id']}.mcap", derived=scene_channels(PLANT),
                                       metadata={"run_id": case["run_id"], "from_snapshot": f"t = {snap.time:.3f} s",
                                                 **{k: str(v) for k, v in case["parameters"].items()}}))
    return _execute(("branch", digest, fmu_dir), system, observers, metrics, base, case, started,
                    lambda ex: ex.restart(None, observers, system.faults, resume=snap), snap)


def _monitor(base: dict) -> list:
    """The requirements' observer of keep.requirements (a fresh one a run), or none."""
    if not base.get("requirements"):
        return []
    from ...engine.requirements import requirement

    return [RequirementObserver([requirement(name, text) for name, text in base["requirements"]])]


_WHOLE: dict[str, tuple] = {}  # per worker process: FMU path -> its (size, mtime, inode) when last found whole


def check_fmus(system) -> None:
    """Every FMU of the system is a file on this worker and a whole zip archive (read again only when the file
    changed: a stat a run, not an archive's directory)."""
    for spec in system.instances:
        path = str(spec.fmu)
        try:
            st = os.stat(path)
        except OSError:
            st = None
        if st is None or not stat.S_ISREG(st.st_mode):
            raise MissingFmu(f"no FMU at {spec.fmu}")
        seen = (st.st_size, st.st_mtime_ns, st.st_ino)
        if _WHOLE.get(path) == seen:
            continue
        if not zipfile.is_zipfile(path):
            raise MissingFmu(f"{spec.fmu} is not a whole FMU (not a zip archive)")
        _WHOLE[path] = seen


def _run_case(base: dict, case: dict, fmu_dir: str, log_dir: str | None) -> dict:
    started = time.perf_counter()
    _CHECKED.update(base.get("feasibility", {}))  # the client's verdicts (feasibility_verdicts)
    if case["controller"] not in ("dlqr", "mixed") and not Path(case["controller"]).is_file():
        raise MissingFmu(f"no controller FMU at {case['controller']}")  # read while the system is described
    try:
        system = case_system(Path(fmu_dir), base, case["controller"], case["seed"], case["parameters"])
    except DescriptionError as err:  # the case's own (its controller file is not an FMU, or not one of a tick's period)
        return {"row": error_row(case, str(err)), "wall": time.perf_counter() - started, "setup": 0.0, "sim_time": 0.0}
    check_fmus(system)
    stop = base["stop_time"] or default_stop(_flight(base).trajectory)
    refused = infeasible(system, stop, _flight(base))
    if refused:  # before the first step, as tiltload run refuses it
        return {"row": error_row(case, refused), "wall": time.perf_counter() - started, "setup": 0.0, "sim_time": 0.0}
    metrics = CampaignMetrics(bounds=base["scenario"] == "zse", settle=min(5.0, stop / 2))
    observers = [metrics, *_monitor(base)]
    if log_dir:
        observers.insert(0, McapLogger(Path(log_dir) / f"{case['run_id']}.mcap", derived=scene_channels(PLANT),
                                       metadata={"run_id": case["run_id"], **case["parameters"]}))
    return _execute(execution_key(base, case, fmu_dir), system, observers, metrics, base, case, started,
                    lambda ex: ex.restart({i.name: i.parameters for i in system.instances}, observers, system.faults))


def _execute(key, system, observers, metrics, base, case, started, restart, resume=None) -> dict:
    """Run the case on this worker's execution of its structure (restarted), or a new one; its outcome."""
    stop = base["stop_time"] or default_stop(_flight(base).trajectory)
    execution = _EXECUTIONS.pop(key, None)
    error = None
    healthy = False
    try:
        if execution is None:
            execution = Execution(system, observers, isolate=is_foreign)
            if resume is not None:  # the FMUs' digests and the parameters, before anything is loaded
                from ...engine.snapshot import check

                check(execution, resume)
            execution.instantiate(resume)
        else:
            restart(execution)
        setup = time.perf_counter() - started
        execution.run(stop)
        healthy = True
    except RUN_FAILURES as err:  # the run's one line; the row keeps it
        setup = time.perf_counter() - started
        error = str(err)
        healthy = True
    finally:
        if execution is not None:
            for obs in execution.observers:
                try:
                    obs.finish(execution, error)
                except Exception:
                    pass
            execution.observers = []
            if not healthy or any(i.fatal for i in execution.instances.values()):
                execution.close()  # after fmi2Fatal or a failure outside the run: the next run starts afresh
            else:
                _EXECUTIONS[key] = execution
    sim_time = execution.time if execution is not None else 0.0
    diverged = error is not None and ("diverged" in error or "non-finite" in error)
    row = {"run_id": case["run_id"], "controller": Path(case["controller"]).stem if case["controller"] not in ("dlqr", "mixed")
           else case["controller"], "seed": case["seed"], **case["values"],
           **metrics.row(tuple(base["keep_metrics"])), "completed": error is None, "diverged": diverged,
           "diverged_at": sim_time if diverged else math.nan, "error": error or ""}
    for obs in observers:
        if isinstance(obs, RequirementObserver):  # NAME_verdict, NAME_robustness (NaN: undecided)
            results = {r.name: r for r in obs.results}
            for name, _ in base.get("requirements", ()):
                r = results.get(name)
                row[f"{name}_verdict"] = r.shown if r is not None else "INCONCLUSIVE"  # "PASS (vacuous)" too
                row[f"{name}_robustness"] = r.robustness if r is not None and r.robustness is not None else math.nan
    return {"row": row, "wall": time.perf_counter() - started, "setup": setup, "sim_time": sim_time}

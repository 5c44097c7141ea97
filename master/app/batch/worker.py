"""What a process that runs many cases keeps between them (a Dask worker of a campaign or a falsification; a test or a
calibration that runs cases in its own process): the execution pool (engine/lifecycle.py: one execution per system
structure, restarted per run, cheaper than instantiating four FMUs a run: benchmarks/campaign.py), the feasibility
verdicts, the snapshots read, the FMU files found whole and the parsed formulas.

A Dask worker's state hangs off the worker itself (`this_worker`), never off a module: each worker process has one.

What a run produced is its outcome, a row: completed, or failed with its one line (the engine's DescriptionError or
ExecutionError: an FMU refused a value, the loop diverged, an FMU reported an error). Anything else (an FMU file this
worker cannot see, an import error, memory, a bug) is a failure of the environment, not of the run: it comes back as
such, with the worker's address, for the campaign to try again elsewhere; it is never a row.
"""

from __future__ import annotations

import hashlib
import os
import socket
import stat
import zipfile
from pathlib import Path

from ....plant_fmu.parameters import PARAMETER_NAMES
from ...engine.errors import DescriptionError, ExecutionError
from ...engine.lifecycle import ExecutionPool
from ..case.flight import Flight, LoopBase, flight_of, stop_of
from ..case.system import case_system
from ..feasibility.policy import check_system
from ..loop.fmus import is_foreign
from ..loop.thesis import PLANT

MOST_VERDICTS = 1024  # feasibility verdicts a worker keeps (a moved mission's key holds its knot table: a few KB)
CHECKED = frozenset((*PARAMETER_NAMES, "f_min", "f_max", "tau_max"))  # feasibility.check_system's plant parameters
RUN_FAILURES = (DescriptionError, ExecutionError)  # the engine's word on the run itself: kept as its outcome
ATTRIBUTE = "tiltload_cases"  # the Dask worker's attribute that holds its CaseWorker


class MissingFmu(FileNotFoundError):
    """An FMU file of the run is not on this worker (or not a whole FMU): its environment, not the run."""


class CaseWorker:
    """The state one process keeps across the cases it runs."""

    def __init__(self, keep: bool = True) -> None:
        self.pool = ExecutionPool(keep)  # keep=False: every run's execution closed after it
        self.verdicts: dict[tuple, str | None] = {}  # the feasibility check's first problem per reference, plant, stop
        self.whole: dict[str, tuple] = {}  # FMU path -> its (size, mtime, inode) when last found whole
        self.snapshots: dict[str, object] = {}  # by digest (one campaign at a time): read once
        self.formulas: dict[str, object] = {}  # STL text -> its parsed formula
        self.branch_points: dict[tuple, object] = {}  # a falsification's snapshot of its base case (one base at a time)

    def close(self) -> None:
        self.pool.close()

    def infeasible(self, system, stop: float, flight: Flight) -> str | None:
        """The feasibility check's first problem for this case (None: it may run), once per reference and plant."""
        key = (flight, checked_plant(system.instance(PLANT).parameters), stop)
        if key not in self.verdicts:
            report = check_system(system, stop, flight.max_tilt, explain=False)
            if len(self.verdicts) >= MOST_VERDICTS:  # the oldest goes: a search's every moved mission is a new key
                self.verdicts.pop(next(iter(self.verdicts)))
            self.verdicts[key] = report.problems[0] if report is not None and report.problems else None
        problem = self.verdicts[key]
        return None if problem is None or flight.allow_infeasible else f"the reference is infeasible: {problem}"

    def check_fmus(self, system) -> None:
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
            if self.whole.get(path) == seen:
                continue
            if not zipfile.is_zipfile(path):
                raise MissingFmu(f"{spec.fmu} is not a whole FMU (not a zip archive)")
            self.whole[path] = seen

    def snapshot(self, data: bytes):
        """(digest, the snapshot) of a snapshot file's bytes, read once."""
        from ...engine import snapshot

        digest = hashlib.sha256(data).hexdigest()
        if digest not in self.snapshots:
            self.snapshots.clear()  # one campaign at a time per worker
            self.snapshots[digest] = snapshot.from_bytes(data, "base.snapshot")
        return digest, self.snapshots[digest]

    def formula(self, text: str):
        """An STL formula, parsed once."""
        if text not in self.formulas:
            from ...engine.requirement.stl import parse

            self.formulas[text] = parse(text)
        return self.formulas[text]

    def prepare(self, base: LoopBase, case: dict, fmu_dir: str) -> bool:
        """Instantiate a case's system before its runs come (the FMUs unpacked, loaded and instantiated, as its first
        run would), while the client checks the cases' feasibility: the first run then restarts it. Never raises
        (False: not prepared; the run meets the problem again and reports it)."""
        try:
            system = case_system(Path(fmu_dir), base, case["controller"], case["seed"], case["parameters"])
        except Exception:
            return False
        return self.pool.prepare(system, is_foreign)


def ready() -> bool:
    """Nothing: run on each worker of a new local cluster, so that importing this module (seconds: the controller's
    design tools come with the case core) is part of the cluster's start, not of the first run."""
    return True


def checked_plant(parameters: dict) -> tuple:
    """The plant parameters the feasibility check reads (feasibility.check_system: the physical ones and the limits),
    as a key: a case that changes only others (an initial offset, plant.x_0) has the verdict of one that does not."""
    return tuple(sorted((k, repr(v)) for k, v in parameters.items() if k in CHECKED))


M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3  # glibc's mallopt parameters (as its malloc header numbers them)
FREED_KEPT, OWN_MAPPING = 64 << 20, 4 << 20  # bytes


def keep_freed_memory() -> bool:
    """glibc's malloc in a process that runs thousands of cases keeps what it frees (up to FREED_KEPT at the heap's
    top; an allocation is a mapping of its own only from OWN_MAPPING). Why: Dask starts its workers with
    MALLOC_TRIM_THRESHOLD_=65536 (its nanny's pre-spawn-environ), which also fixes that mapping threshold at 128 KB:
    a moved mission's feasibility check then maps, faults in page by page and unmaps its 100-200 KB arrays at every
    evaluation (80-110 page faults, 0.2 ms of 6.4: docs/throughput.md). False where the C library is not glibc."""
    import ctypes
    import platform

    if platform.libc_ver()[0] != "glibc":
        return False
    mallopt = getattr(ctypes.CDLL(None), "mallopt", None)
    if mallopt is None:
        return False
    mallopt.argtypes, mallopt.restype = [ctypes.c_int, ctypes.c_int], ctypes.c_int
    return bool(mallopt(M_TRIM_THRESHOLD, FREED_KEPT)) and bool(mallopt(M_MMAP_THRESHOLD, OWN_MAPPING))


def this_worker() -> CaseWorker:
    """The CaseWorker of the Dask worker running this (made on its first task); outside a worker, a new one that keeps
    no execution (a caller that runs many cases in its own process makes a CaseWorker and passes it)."""
    try:
        from distributed import get_worker

        dask_worker = get_worker()
    except (ImportError, ValueError):
        return CaseWorker(keep=False)
    state = getattr(dask_worker, ATTRIBUTE, None)
    if state is None:
        keep_freed_memory()
        state = CaseWorker()
        setattr(dask_worker, ATTRIBUTE, state)
    return state


def prepare(base: LoopBase, case: dict, fmu_dir: str) -> bool:
    """The Dask task: this worker prepares a case's system (CaseWorker.prepare)."""
    return this_worker().prepare(base, case, fmu_dir)


def feasibility_verdicts(base: LoopBase, cases: list[dict], fmu_dir: str, most: int = 16) -> dict:
    """The feasibility check's verdicts of the first case of each set of plant parameters the cases vary (at most
    `most` sets), for the client to compute once and hand to every worker in base.feasibility: each worker would
    otherwise check them itself (1-2 ms each, compiled: docs/throughput.md). A case this cannot describe is left to
    its worker, and so is any verdict missed here (looked up by the same key, computed where missing)."""
    checker = CaseWorker()
    stop = stop_of(base)
    seen: set[tuple] = set()
    for case in cases:
        plant = checked_plant({k.partition(".")[2]: v for k, v in case["parameters"].items() if k.startswith(f"{PLANT}.")})
        if plant in seen or len(seen) >= most:
            continue
        seen.add(plant)
        try:
            checker.infeasible(case_system(Path(fmu_dir), base, case["controller"], case["seed"], case["parameters"]), stop,
                               flight_of(base))
        except Exception:  # noqa: BLE001  (its worker describes it, and says what is wrong)
            continue
    return dict(checker.verdicts)


def worker_address() -> str | None:
    """The address of the Dask worker running this (None outside a worker: called directly)."""
    try:
        from distributed import get_worker

        return get_worker().address
    except (ImportError, ValueError):
        return None


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

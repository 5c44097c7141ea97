"""The runs of a campaign on a Dask cluster, each until it has its outcome.

- A run's outcome (a row: completed, diverged, refused input) is handed to `store` as soon as it arrives (with
  chunks, a task's outcomes to `store_many`).
- A failure of its environment (an FMU its worker cannot see, an import error, memory, its worker killed) is no
  outcome: the run is tried again, on a worker it has not failed on when there is one, `retries` times; then it is
  reported (Dispatch.failures), never stored.
- A cancelled future is no outcome either: the scheduler went away (or someone cancelled the runs), and the campaign
  ends with CampaignIncomplete; what was stored stays, the same command finishes the rest.
- A scheduler without workers for `worker_timeout` seconds (or silent that long) ends it the same way.

With `chunked`, several runs go to a task (`run_chunk`): a task costs the client, the scheduler and the worker a few
ms of messages and (de)serialization, as much as a short run's simulation. Their sizes shrink as the runs left do
(guided self-scheduling, `chunk_size`): the first tasks carry several runs, the last ones fewer, so that no worker is
left with a long task when the others are done; but once runs have come back, never fewer than TASK_SECONDS of runs
(`_bounds`), so that the last tasks of short runs do not cost more in messages than their runs, nor more than
TASK_SECONDS[1] of runs (what a killed worker takes with it). A task's outcomes are
stored together (`store_many`: one Parquet part); a run whose environment failed is tried again alone. A search's
batch, whose runs are awaited together, goes as one task a worker (`even_chunks`). At most a window of tasks
(2 x PER_WORKER a thread, at most WINDOW; two a thread until runs have come back) is submitted and not yet settled;
the next is made and submitted as one settles, its size decided then.
"""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Callable
from concurrent.futures import CancelledError
from dataclasses import dataclass, field

from ..case.case_set import Case
from ..loop.defaults import WORKER_TIMEOUT
from .cluster import first_line
from .errors import CampaignIncomplete
from .logs import LOGGER

POLL = 0.1  # s between looks at the cluster's health at most while nothing finishes (a finish wakes the wait at once)
HEALTH = 1.0  # s between looks at the cluster while nothing finishes
PER_WORKER = 2  # chunks: a task carries at most 1/(PER_WORKER x workers) of the runs left (2: a third fewer tasks than 4, the
# same balance at the end: docs/throughput.md)
MOST = 16  # ... and at most this many runs (what a killed worker takes with it) before the runs' length is known
TASK_SECONDS = (0.02, 0.25)  # then at least and at most this much work (a task's messages cost a worker about 2.4 ms of
# CPU, the client and its scheduler as much again: docs/throughput.md) ...
SHORTEST = 256  # ... and never more runs than this
WINDOW = 64  # tasks submitted and not yet settled, at most (2 x PER_WORKER a thread below that): the rest wait in the
# client as cases, so the client and the local cluster's scheduler (in its process) hold a window, not every task of
# 20,000 runs at once (all 1268 tasks submitted at once cost the client 90 MB: benchmarks/scale_20k.py)


def chunk_size(left: int, workers: int, floor: int = 1, most: int = MOST) -> int:
    """The size of the next task when `left` runs are left on `workers` workers: the runs left / (PER_WORKER x
    workers), rounded up, at most `most`, at least floor (all that is left, if less)."""
    return min(left, most, max(floor, 1, math.ceil(left / (PER_WORKER * max(workers, 1)))))


def chunk_sizes(runs: int, workers: int, floor: int = 1, most: int = MOST) -> list[int]:
    """The sizes of the tasks that carry `runs` runs, each decided by chunk_size; with floor 1 the last is 1."""
    sizes, left = [], runs
    while left > 0:
        sizes.append(chunk_size(left, workers, floor, most))
        left -= sizes[-1]
    return sizes


def even_chunks(runs: int, workers: int) -> list[int]:
    """Sizes of the tasks that carry a batch whose runs are all awaited together (a search's batch or group, sized to
    about TASK_SECONDS[1] a worker: falsify/search.py): one task a worker (more when that is more than SHORTEST runs a
    task), as equal as they can be (the larger first), so that a batch costs each worker one task's messages, not one a
    run. More than SHORTEST runs a worker: a whole number of tasks a worker, so that no worker is left alone with the
    last task while the others wait."""
    workers = max(workers, 1)
    tasks = max(1, min(runs, workers * math.ceil(runs / (workers * SHORTEST))))
    return [runs // tasks + (k < runs % tasks) for k in range(tasks)] if runs else []


def _tasks(cases: list[Case], next_size: Callable[[int], int]):
    """The first tries of the cases, grouped a task each, made as they are submitted: next_size(runs left) is the
    next task's size."""
    at = 0
    while at < len(cases):
        size = next_size(len(cases) - at)
        yield [_Attempt(case) for case in cases[at:at + size]]
        at += size


@dataclass(frozen=True)
class Runs:
    """A task's cases as one argument Dask does not look into (it walks a plain list of dicts for futures: a tenth of a
    millisecond a run in the client)."""

    cases: tuple


@dataclass(frozen=True)
class Outcomes:
    """A task's outcomes pickled on the worker's task thread, so that Dask's messages carry bytes: a list of row dicts
    cost the worker's event loop about 30 µs a row to size and send (docs/throughput.md)."""

    data: bytes

    def load(self) -> list[dict]:
        import pickle

        return pickle.loads(self.data)  # written by run_chunk on our own worker (Dask unpickles its results alike)


def run_chunk(task: Callable[..., dict], runs: Runs, **shared) -> Outcomes:
    """A task of several runs, on a worker: each run's outcome, in order (task never raises: run_case)."""
    import pickle

    return Outcomes(pickle.dumps([task(case, **shared) for case in runs.cases], protocol=pickle.HIGHEST_PROTOCOL))


def _fields(case: Case) -> dict:
    """A case as the task takes it: its fields (a shallow copy: the task only reads them; asdict's deep copy cost the
    client as much as the task's messages)."""
    return dict(vars(case))


def cluster_threads(client, timeout: float = 5.0) -> int:
    """How many runs the cluster runs at once (its workers' threads; 1 if the scheduler does not say)."""
    try:
        return max(1, sum(client.nthreads(callback_timeout=timeout).values()))
    except Exception:  # noqa: BLE001  (a scheduler that does not answer: the dispatch says so when it waits)
        return 1


@dataclass
class Policy:
    retries: int = 2  # further tries of a run whose environment failed
    worker_timeout: float = WORKER_TIMEOUT  # s without a worker before the campaign gives up
    answer_timeout: float = 5.0  # s for the scheduler to answer a question


@dataclass
class _Attempt:
    case: Case
    number: int = 0  # 0: the first try
    failed_on: set[str] = field(default_factory=set)  # workers where its environment failed
    allowed: frozenset[str] | None = None  # the workers it may run on (None: any)


class Dispatch:
    """Submit the runs, collect their outcomes; `where` names the scheduler in the lines; done_before and total count
    the campaign's runs (for the line that says how far it got)."""

    def __init__(self, client, task: Callable[[dict], dict], store: Callable[[dict], None], where: str, total: int,
                 done_before: int, policy: Policy | None = None, progress: Callable[[str], None] | None = None,
                 shared: dict | None = None, chunked: bool = False,
                 store_many: Callable[[list[dict]], None] | None = None,
                 sizes: Callable[[int, int], list[int]] | None = None, started: float | None = None) -> None:
        self.client, self.task, self.store, self.where = client, task, store, where
        self.started = started  # the caller's clock (time.perf_counter(), its cluster's start included); None: run()'s
        self.chunked = chunked  # several runs a task: chunk_size's, decided as each task is made; or all at once by
        self.sizes = sizes  # sizes(runs, workers) (even_chunks, for a batch)
        self.store_many = store_many  # stores a task's outcomes at once (default: store, one by one)
        self.shared = shared or {}  # keyword arguments of every run: futures of data scattered once (a snapshot)
        self.total, self.done_before = total, done_before
        self.policy = policy or Policy()
        self.say = progress or (lambda _: None)
        self.pending: dict = {}  # future -> its _Attempts (the futures must stay referenced, or Dask forgets their tasks)
        self.stored = 0
        self.failed = 0  # stored rows of failed runs (data)
        self.retried = 0
        self.failures: dict[str, str] = {}  # run id -> the line of its environment's last failure (not stored)
        self.finished = None  # as_completed over the pending futures
        self._submitted = 0
        self._walls = [0.0, 0]  # the stored runs' wall seconds, summed, and their count (_floor)

    def run(self, cases: list[Case]) -> None:
        from dask.distributed import as_completed

        if self.client.status != "running":
            self._lost()
        started = self.started if self.started is not None else time.perf_counter()
        threads = self._threads()
        fixed = iter(self.sizes(len(cases), threads)) if self.chunked and self.sizes is not None else None

        def next_size(left: int) -> int:
            if not self.chunked:
                return 1
            return next(fixed) if fixed is not None else chunk_size(left, threads, *self._bounds())
        window = min(WINDOW, 2 * PER_WORKER * threads)
        tasks = iter(_tasks(cases, next_size))
        # two tasks a thread to start with: the rest are sized once the first runs have said how long a run takes
        for group in itertools.islice(tasks, window if fixed is not None else min(window, 2 * threads)):
            self._submit(*group)
        finished = self.finished = as_completed(list(self.pending), loop=self.client.loop, with_results=False)
        last_look, alone_since = time.monotonic(), None
        while not finished.is_empty():
            batch = finished.next_batch(block=False)
            for future in batch:
                if future not in self.pending:  # replaced (_look)
                    continue
                for again in self._settle(future, len(cases), started):
                    finished.add(again)
            for group in itertools.islice(tasks, max(0, window - len(self.pending))):  # the window topped up
                finished.add(self._submit(*group))
            if batch:
                last_look, alone_since = time.monotonic(), None
                continue
            self._wait()
            if time.monotonic() - last_look >= HEALTH:
                last_look = time.monotonic()
                alone_since = self._look(alone_since)

    def _bounds(self) -> tuple[int, int]:
        """The fewest and the most runs a task carries: TASK_SECONDS of the runs stored so far (1 and MOST before any;
        never fewer than MOST at most, nor more than SHORTEST)."""
        total, count = self._walls
        if not count or total <= 0:
            return 1, MOST
        least, most = math.ceil(TASK_SECONDS[0] * count / total), int(TASK_SECONDS[1] * count / total)
        return min(MOST, least), min(SHORTEST, max(MOST, most))

    def _wait(self) -> None:
        """Until a pending future finishes, at most POLL s: woken by as_completed's own notice of a finish (its
        thread_condition, which its blocking iteration waits on), so a search's batch of 8 ms runs is judged as soon as
        it is back. distributed.wait() did the same at 0.6 ms of the client's event loop a call, a few calls a batch
        (docs/throughput.md)."""
        finished = self.finished
        with finished.thread_condition:
            if not finished.has_ready():
                finished.thread_condition.wait(timeout=POLL)

    def _submit(self, *attempts: _Attempt):
        """The future of a task of these runs (several: a chunk of first tries); a run after failures of its
        environment goes alone, to the workers it has not failed on (any if none is left). Strictly there: with a
        loose restriction Dask's work stealing hands it to an idle worker, the failing one."""
        attempt = attempts[0]
        attempt.allowed = None
        if attempt.failed_on:
            attempt.allowed = frozenset(w for w in self._workers() if w not in attempt.failed_on) or None
        self._submitted += 1
        suffix = f"-try{attempt.number + 1}-{self._submitted}" if attempt.number or attempt.allowed else ""
        where = {"workers": sorted(attempt.allowed) if attempt.allowed else None, "allow_other_workers": False}
        if len(attempts) == 1 and not self.chunked:
            future = self.client.submit(self.task, _fields(attempt.case), **self.shared,
                                        key=f"run-{attempt.case.run_id}{suffix}", pure=False, **where)
        else:
            future = self.client.submit(run_chunk, self.task, Runs(tuple(_fields(a.case) for a in attempts)), **self.shared,
                                        key=f"runs-{attempt.case.run_id}+{len(attempts)}{suffix}", pure=False, **where)
        self.pending[future] = attempts
        return future

    def _resubmit_stranded(self, workers: set[str]) -> None:
        """A run restricted to workers that are all gone would wait for ever: submitted again (not a further try)."""
        for future, attempts in list(self.pending.items()):
            allowed = attempts[0].allowed
            if allowed is not None and not allowed & workers:
                del self.pending[future]
                future.cancel()
                LOGGER.info("run %s: the workers it was left to are gone; submitted again", attempts[0].case.run_id)
                self.finished.add(self._submit(*attempts))

    def _threads(self) -> int:
        return cluster_threads(self.client, self.policy.answer_timeout)

    def _workers(self) -> list[str]:
        return sorted(self._workers_or_none() or ())

    def _workers_or_none(self) -> set[str] | None:
        """The scheduler's workers now; None if it did not say within answer_timeout."""
        try:
            return set(self.client.nthreads(callback_timeout=self.policy.answer_timeout))
        except Exception:
            return None

    def _result(self, future):
        """future.result(), waited for while a worker is left: Dask computes again an outcome whose worker died before
        it was fetched, and with no worker left that wait would never end."""
        while True:
            try:
                return future.result(timeout=HEALTH)
            except TimeoutError:
                if self.client.status != "running" or self._workers_or_none() == set():
                    future.cancel()
                    raise RuntimeError("its worker is gone and no worker is left to run it again") from None

    def _settle(self, future, runs: int, started: float) -> list:
        """Store the outcomes of a finished future; the futures of the next tries of the runs whose environment
        failed."""
        attempts = self.pending.pop(future)
        status = future.status
        if status == "cancelled":
            self._lost(future)
        if status == "error":
            err = future.exception()
            from distributed.scheduler import KilledWorker

            if isinstance(err, KilledWorker):  # Dask already tried it on several workers: each died under it
                return self._environments(attempts, "its worker died each time it ran it (a crash, or out of memory)",
                                          None, final=True)
            return self._environments(attempts, f"{type(err).__name__}: {first_line(err)}", None)
        try:
            results = self._result(future)
        except CancelledError:
            self._lost(future)
        except Exception as err:  # the outcome could not be fetched (its worker went away meanwhile)
            if self.client.status != "running":
                self._lost(future)
            return self._environments(attempts, f"its result could not be fetched: {first_line(err)}", None)
        results = results.load() if isinstance(results, Outcomes) else [results]
        again, outcomes = [], []
        for attempt, result in zip(attempts, results):
            if "environment" in result:
                again += self._environments([attempt], result["environment"], result.get("worker"))
            else:
                outcomes.append(result)
        if outcomes:
            if self.store_many is not None:
                self.store_many(outcomes)
            else:
                for result in outcomes:
                    self.store(result)
        for result in outcomes:
            self._walls[0] += float(result.get("wall") or 0.0)
            self._walls[1] += 1
            self.stored += 1
            self.failed += not result["row"]["completed"]
        done = self.stored + len(self.failures)
        elapsed = time.perf_counter() - started
        others = "".join(f", {n} {what}" for n, what in ((self.retried, "retried"), (len(self.failures), "not run"))
                         if n)
        if outcomes and done:
            self.say(f"  {done}/{runs} runs ({self.failed} failed{others}), {elapsed:.0f} s, "
                     f"about {elapsed / done * (runs - done):.0f} s left")
        return again

    def _environments(self, attempts: list[_Attempt], line: str, worker: str | None, final: bool = False) -> list:
        """The futures of the next tries of these runs (none for those given up)."""
        futures = [self._environment(a, line, worker, final) for a in attempts]
        return [f for f in futures if f is not None]

    def _environment(self, attempt: _Attempt, line: str, worker: str | None, final: bool = False):
        run = f"run {attempt.case.run_id} ({attempt.case.controller}, seed {attempt.case.seed})"
        if final or attempt.number >= self.policy.retries:
            LOGGER.error("%s: its environment failed on try %d, given up: %s", run, attempt.number + 1, line)
            self.failures[attempt.case.run_id] = line
            return None
        LOGGER.warning("%s: its environment failed on try %d, trying again: %s", run, attempt.number + 1, line)
        self.retried += 1
        failed_on = attempt.failed_on | ({worker} if worker else set())
        return self._submit(_Attempt(attempt.case, attempt.number + 1, failed_on))

    def _look(self, alone_since: float | None) -> float | None:
        """While nothing finishes: is the scheduler there, with workers? When it has had none for too long: the end."""
        if self.client.status != "running":
            self._lost()
        workers = self._workers_or_none()
        count = None if workers is None else len(workers)
        if count:
            self._resubmit_stranded(workers)
            return None
        now = time.monotonic()
        alone_since = alone_since or now
        if now - alone_since >= self.policy.worker_timeout:
            what = "has had no workers" if count == 0 else "has not answered"
            raise CampaignIncomplete(f"the scheduler at {self.where} {what} for {self.policy.worker_timeout:g} s "
                                     f"(--worker-timeout) after {self._progress()}; start workers and rerun the same "
                                     "command to finish")
        return alone_since

    def _progress(self) -> str:
        return f"{self.done_before + self.stored} of {self.total} runs"

    def _lost(self, future=None):
        reason = None
        if future is not None:
            try:
                future.result()
            except CancelledError as err:
                reason = getattr(err, "reason", None)
            except Exception:
                pass
        LOGGER.error("stopped after %s: the client is %s, the runs were cancelled for %s", self._progress(),
                     self.client.status, reason)
        if self.client.status != "running" or reason in (None, "unknown", "scheduler-connection-lost"):
            raise CampaignIncomplete(f"the scheduler at {self.where} went away after {self._progress()}; "
                                     "rerun the same command to finish")
        raise CampaignIncomplete(f"the runs were cancelled on the scheduler at {self.where} ({reason}) after "
                                 f"{self._progress()}; rerun the same command to finish")

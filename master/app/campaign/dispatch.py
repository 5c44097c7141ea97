"""The runs of a campaign on a Dask cluster, each until it has its outcome.

- A run's outcome (a row: completed, diverged, refused input) is handed to `store` as soon as it arrives.
- A failure of its environment (an FMU its worker cannot see, an import error, memory, its worker killed) is no
  outcome: the run is tried again, on a worker it has not failed on when there is one, `retries` times; then it is
  reported (Dispatch.failures), never stored.
- A cancelled future is no outcome either: the scheduler went away (or someone cancelled the runs), and the campaign
  ends with CampaignIncomplete; what was stored stays, the same command finishes the rest.
- A scheduler without workers for `worker_timeout` seconds (or silent that long) ends it the same way.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from concurrent.futures import CancelledError
from dataclasses import asdict, dataclass, field

from .cluster import first_line
from .errors import CampaignIncomplete
from .logs import LOGGER
from .spec import Case

POLL = 0.02  # s between looks at the finished futures
HEALTH = 1.0  # s between looks at the cluster while nothing finishes


@dataclass
class Policy:
    retries: int = 2  # further tries of a run whose environment failed
    worker_timeout: float = 30.0  # s without a worker before the campaign gives up
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
                 done_before: int, policy: Policy | None = None, progress: Callable[[str], None] | None = None) -> None:
        self.client, self.task, self.store, self.where = client, task, store, where
        self.total, self.done_before = total, done_before
        self.policy = policy or Policy()
        self.say = progress or (lambda _: None)
        self.pending: dict = {}  # future -> _Attempt (the futures must stay referenced, or Dask forgets their tasks)
        self.stored = 0
        self.failed = 0  # stored rows of failed runs (data)
        self.retried = 0
        self.failures: dict[str, str] = {}  # run id -> the line of its environment's last failure (not stored)
        self.finished = None  # as_completed over the pending futures
        self._submitted = 0

    def run(self, cases: list[Case]) -> None:
        from dask.distributed import as_completed

        if self.client.status != "running":
            self._lost()
        started = time.perf_counter()
        for case in cases:
            self._submit(_Attempt(case))
        finished = self.finished = as_completed(list(self.pending), loop=self.client.loop, with_results=False)
        last_look, alone_since = time.monotonic(), None
        while not finished.is_empty():
            batch = finished.next_batch(block=False)
            for future in batch:
                if future not in self.pending:  # replaced (_look)
                    continue
                again = self._settle(future, len(cases), started)
                if again is not None:
                    finished.add(again)
            if batch:
                last_look, alone_since = time.monotonic(), None
                continue
            time.sleep(POLL)
            if time.monotonic() - last_look >= HEALTH:
                last_look = time.monotonic()
                alone_since = self._look(alone_since)

    def _submit(self, attempt: _Attempt):
        """Its future; after failures of its environment, on the workers it has not failed on (any if none is left).
        Strictly there: with a loose restriction Dask's work stealing hands it to an idle worker, the failing one."""
        attempt.allowed = None
        if attempt.failed_on:
            attempt.allowed = frozenset(w for w in self._workers() if w not in attempt.failed_on) or None
        self._submitted += 1
        suffix = f"-try{attempt.number + 1}-{self._submitted}" if attempt.number or attempt.allowed else ""
        future = self.client.submit(self.task, asdict(attempt.case), key=f"run-{attempt.case.run_id}{suffix}", pure=False,
                                    workers=sorted(attempt.allowed) if attempt.allowed else None, allow_other_workers=False)
        self.pending[future] = attempt
        return future

    def _resubmit_stranded(self, workers: set[str]) -> None:
        """A run restricted to workers that are all gone would wait for ever: submitted again (not a further try)."""
        for future, attempt in list(self.pending.items()):
            if attempt.allowed is not None and not attempt.allowed & workers:
                del self.pending[future]
                future.cancel()
                LOGGER.info("run %s: the workers it was left to are gone; submitted again", attempt.case.run_id)
                self.finished.add(self._submit(attempt))

    def _workers(self) -> list[str]:
        return sorted(self._workers_or_none() or ())

    def _workers_or_none(self) -> set[str] | None:
        """The scheduler's workers now; None if it did not say within answer_timeout."""
        try:
            return set(self.client.nthreads(callback_timeout=self.policy.answer_timeout))
        except Exception:
            return None

    def _settle(self, future, runs: int, started: float):
        """Store the outcome of a finished future; the future of its next try when its environment failed."""
        attempt = self.pending.pop(future)
        status = future.status
        if status == "cancelled":
            self._lost(future)
        if status == "error":
            err = future.exception()
            from distributed.scheduler import KilledWorker

            if isinstance(err, KilledWorker):  # Dask already tried it on several workers: each died under it
                return self._environment(attempt, "its worker died each time it ran it (a crash, or out of memory)",
                                         None, final=True)
            return self._environment(attempt, f"{type(err).__name__}: {first_line(err)}", None)
        try:
            result = future.result()
        except CancelledError:
            self._lost(future)
        except Exception as err:  # the outcome could not be fetched (its worker went away meanwhile)
            if self.client.status != "running":
                self._lost(future)
            return self._environment(attempt, f"its result could not be fetched: {first_line(err)}", None)
        if "environment" in result:
            return self._environment(attempt, result["environment"], result.get("worker"))
        self.store(result)
        self.stored += 1
        self.failed += not result["row"]["completed"]
        done = self.stored + len(self.failures)
        elapsed = time.perf_counter() - started
        others = "".join(f", {n} {what}" for n, what in ((self.retried, "retried"), (len(self.failures), "not run"))
                         if n)
        self.say(f"  {done}/{runs} runs ({self.failed} failed{others}), {elapsed:.0f} s, "
                 f"about {elapsed / done * (runs - done):.0f} s left")
        return None

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

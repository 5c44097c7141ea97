"""What makes campaigns scale keeps their results: FMUs reset between runs give the rows fresh instances give, bit
for bit; several runs a task, their sizes, and a run of a task whose environment failed tried again alone."""

from __future__ import annotations

import math
from dataclasses import asdict
from pathlib import Path

import pytest
from tiltload.master.app.batch import dispatch
from tiltload.master.app.batch.worker import CaseWorker, this_worker
from tiltload.master.app.campaign import run_case
from tiltload.master.app.campaign.spec import load

SPEC = """
name = "reuse"
[base]
scenario = "{scenario}"
trajectory = 1
controllers = ["mixed", "dlqr"]
stop_time = 2.0
[vary]
seeds = [3, 8]
[[vary.parameters]]
name = "load_mass"
targets = ["plant.m_L"]
values = [0.05, 0.3]
"""


def _same(a: dict, b: dict) -> bool:
    """Equal rows, NaN equal to NaN, floats bit for bit."""
    return a.keys() == b.keys() and all(
        (isinstance(x, float) and isinstance(y, float) and math.isnan(x) and math.isnan(y)) or x == y
        for x, y in ((a[k], b[k]) for k in a))


@pytest.mark.slow
@pytest.mark.parametrize("scenario", ["fsi", "zse"])
def test_runs_on_reset_fmus_give_the_rows_of_fresh_instances_bit_for_bit(fmus, tmp_path, scenario):
    spec = tmp_path / "reuse.toml"
    spec.write_text(SPEC.format(scenario=scenario))
    campaign = load(spec)
    base, cases = campaign.base(), [asdict(c) for c in campaign.cases]
    order = cases[::-1] + cases  # each case after a different one: the reset leaves nothing of the run before
    worker = CaseWorker()
    try:
        reused = [run_case.run_case(base, case, str(fmus), None, worker=worker)["row"] for case in order]
        # dlqr and mixed are one controller FMU with other parameters: one structure, one execution restarted for
        # every other run, whichever controller it ran before
        assert len(worker.pool) == 1 and worker.pool.instantiated == 1
    finally:
        worker.close()
    fresh = [run_case.run_case(base, case, str(fmus), None, worker=CaseWorker(keep=False))["row"] for case in order]
    assert all(r["completed"] for r in fresh)
    assert all(_same(a, b) for a, b in zip(reused, fresh))
    assert all(_same(a, b) for a, b in zip(reused[:len(cases)][::-1], reused[len(cases):]))  # and each run twice alike


def test_the_first_run_restarts_the_prepared_execution_and_gives_a_fresh_instances_row(fmus, tmp_path):
    """CaseWorker.prepare instantiates a case's system before the runs come (each worker does it while the client checks
    the feasibility): the first run restarts that execution, and its row is the row of fresh instances, bit for bit. A
    system that cannot be instantiated is not prepared, and prepare says so rather than raise."""
    spec = tmp_path / "reuse.toml"
    spec.write_text(SPEC.format(scenario="fsi"))
    campaign = load(spec)
    base, cases = campaign.base(), [asdict(c) for c in campaign.cases]
    first, later = cases[0], next(c for c in cases[1:] if c["controller"] == cases[0]["controller"])

    fresh = run_case.run_case(base, later, str(fmus), None, worker=CaseWorker(keep=False))["row"]
    worker = CaseWorker()
    try:
        assert worker.prepare(base, first, str(fmus))
        (prepared,) = worker.pool.executions()
        row = run_case.run_case(base, later, str(fmus), None, worker=worker)["row"]
        assert worker.pool.executions() == [prepared] and worker.pool.instantiated == 1  # restarted, not instantiated again
        assert row["completed"] and _same(row, fresh)
        assert worker.prepare(base, first, str(fmus))  # prepared already: nothing more
        assert not worker.prepare(base, first, str(tmp_path / "no_fmus_here"))
        assert worker.pool.executions() == [prepared]
    finally:
        worker.close()


@pytest.mark.parametrize("runs, workers", [(1, 1), (12, 1), (48, 2), (1000, 2), (7, 8)])
def test_chunks_shrink_to_single_runs_and_carry_every_run_once(runs, workers):
    sizes = dispatch.chunk_sizes(runs, workers)
    assert sum(sizes) == runs and all(1 <= s <= dispatch.MOST for s in sizes)
    assert sizes == sorted(sizes, reverse=True) and sizes[-1] == 1
    left = runs
    for s in sizes:  # no task carries more than its share of what is left
        assert s <= max(1, math.ceil(left / (dispatch.PER_WORKER * workers)))
        left -= s
    assert len(sizes) < runs or runs <= dispatch.PER_WORKER * workers


def test_a_floor_keeps_the_last_tasks_at_that_many_runs():
    unfloored = dispatch.chunk_sizes(200, 1)
    assert unfloored[-1] == 1 and unfloored == sorted(unfloored, reverse=True)  # shrinking to a single run
    sizes = dispatch.chunk_sizes(200, 1, floor=4)
    assert sum(sizes) == 200 and all(s >= 4 for s in sizes[:-1]) and sizes[-1] >= 1
    assert dispatch.chunk_size(3, 1, floor=4) == 3  # never more than is left


def _short(case: dict) -> dict:
    """A run that says it took 5 ms."""
    return {"row": {"run_id": case["run_id"], "completed": True}, "wall": 0.005, "setup": 0.0, "sim_time": 1.0}


def test_once_runs_have_come_back_no_task_carries_less_than_task_seconds_of_them():
    from dask.distributed import Client, LocalCluster
    from tiltload.master.app.case.case_set import Case

    stored: list[int] = []
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address="127.0.0.1:0") as cluster, \
            Client(cluster, set_as_default=False) as client:
        d = dispatch.Dispatch(client, _short, lambda _: None, "here", 200, 0, chunked=True,
                              store_many=lambda results: stored.append(len(results)))
        d.run([Case(f"r{i}", "mixed", i, {}, {}) for i in range(200)])
    floor, most = math.ceil(dispatch.TASK_SECONDS[0] / 0.005), int(dispatch.TASK_SECONDS[1] / 0.005)
    assert sum(stored) == 200 and d.stored == 200
    assert sum(1 for n in stored if n < floor) <= 1  # the remainder at most, where the plain schedule ends in 1s
    assert len(stored) < len(dispatch.chunk_sizes(200, 1)) and max(stored) <= max(most, dispatch.MOST)


def test_tasks_of_short_runs_carry_up_to_task_seconds_of_them():
    """Runs of 1 ms: once they are known, a task carries up to TASK_SECONDS[1] of them (more than MOST), never more."""
    from dask.distributed import Client, LocalCluster
    from tiltload.master.app.case.case_set import Case

    stored: list[int] = []
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address="127.0.0.1:0") as cluster, \
            Client(cluster, set_as_default=False) as client:
        d = dispatch.Dispatch(client, lambda case: {**_short(case), "wall": 0.001}, lambda _: None, "here", 3000, 0,
                              chunked=True, store_many=lambda results: stored.append(len(results)))
        d.run([Case(f"r{i}", "mixed", i, {}, {}) for i in range(3000)])
    assert sum(stored) == 3000 and dispatch.MOST < max(stored) <= min(dispatch.SHORTEST, dispatch.TASK_SECONDS[1] / 0.001)
    assert stored[:2] == [dispatch.MOST] * 2  # two tasks a thread before any run came back, of MOST runs each


def _flaky(case: dict, marker: str) -> dict:
    """An outcome; for run r0, the first time, its environment's failure."""
    if case["run_id"] == "r0" and not Path(marker).exists():
        Path(marker).touch()
        return {"environment": "no FMU here", "worker": None}
    return {"row": {"run_id": case["run_id"], "completed": True}, "wall": 0.0, "setup": 0.0, "sim_time": 1.0}


@pytest.mark.slow
def test_a_run_of_a_chunk_whose_environment_failed_is_tried_again_alone(tmp_path):
    from functools import partial

    from dask.distributed import Client, LocalCluster
    from tiltload.master.app.case.case_set import Case

    stored: list[list[str]] = []
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address="127.0.0.1:0") as cluster, \
            Client(cluster, set_as_default=False) as client:
        d = dispatch.Dispatch(client, partial(_flaky, marker=str(tmp_path / "failed-once")), lambda _: None, "here", 6, 0,
                              chunked=True, store_many=lambda results: stored.append([r["row"]["run_id"] for r in results]))
        d.run([Case(f"r{i}", "mixed", i, {}, {}) for i in range(6)])
    assert dispatch.chunk_sizes(6, 1) == [3, 2, 1]  # r0, r1 and r2 a task, then r3 and r4, then r5
    assert sorted(r for part in stored for r in part) == [f"r{i}" for i in range(6)]
    assert ["r1", "r2"] in stored and ["r0"] in stored  # r1, r2 stored with their task, r0 after its second try, alone
    assert d.retried == 1 and d.stored == 6 and not d.failures


def _worker_state(n: int) -> tuple[bool, int, bool]:
    """(the state is the Dask worker's own, how many tasks it has seen, whether it keeps executions)."""
    from distributed import get_worker
    from tiltload.master.app.batch.worker import ATTRIBUTE

    state = this_worker()
    state.branch_points[("task", n)] = None  # a mark each task leaves on the state it got
    return getattr(get_worker(), ATTRIBUTE) is state, len(state.branch_points), state.pool.keep


@pytest.mark.slow
def test_a_dask_worker_keeps_one_case_worker_across_its_tasks_and_a_plain_caller_keeps_none():
    """The executions a Dask worker reuses hang off the worker (one CaseWorker for all its tasks); a call outside a
    worker gets one that keeps no execution (nothing of it outlives the call)."""
    from dask.distributed import Client, LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address="127.0.0.1:0") as cluster, \
            Client(cluster, set_as_default=False) as client:
        states = [client.submit(_worker_state, n, pure=False).result() for n in range(3)]
    assert states == [(True, 1, True), (True, 2, True), (True, 3, True)]  # one state, marked by every task in turn
    assert this_worker() is not this_worker() and not this_worker().pool.keep

"""The results a campaign and a search assemble from their parts, against their definition (each run's newest row, in
the spec's order, every column any row has, null where a row lacks it), written out here row by row; and the parts a
search writes: one a batch, or one a group of batches asked ahead (uniform)."""

from __future__ import annotations

import math
import time
from pathlib import Path
from types import SimpleNamespace

import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from tiltload.master.app.campaign import runner
from tiltload.master.app.falsify.search import read_parts, search
from tiltload.master.app.falsify.spec import Dimension


def _outcome(run_id: str, completed: bool, wall: float, **metrics) -> dict:
    row = {"run_id": run_id, "controller": "dlqr", "seed": 1, "load_mass": 0.1, "completed": completed,
           "diverged": False, "diverged_at": None, "error": "" if completed else "refused", **metrics}
    return {"row": row, "wall": wall, "setup": 0.0, "sim_time": 2.0}


def _by_definition(parts: Path, order: list[str]) -> tuple[list[dict], list[dict]]:
    """(results rows, timings rows) from the parts: the newest row of each run, in order; the union of the keys in the
    order the rows bring them, None where a row lacks one."""
    newest: dict[str, dict] = {}
    for path in sorted(parts.glob("*.parquet")):
        for row in pq.read_table(path).to_pylist():
            if row["run_id"] not in newest or row["_stored_at"] >= newest[row["run_id"]]["_stored_at"]:
                newest[row["run_id"]] = row
    chosen = [newest[r] for r in order if r in newest]
    keys = []
    for row in chosen:
        keys += [k for k in row if k not in keys and not k.startswith("_")]
    return ([{k: row.get(k) for k in keys} for row in chosen],
            [{"run_id": r["run_id"], "wall_s": r["_wall"], "setup_s": r["_setup"], "sim_time": r["_sim_time"]} for r in chosen])


def _same(a: list[dict], b: list[dict]) -> bool:
    def norm(r):
        return {k: ("nan" if isinstance(v, float) and math.isnan(v) else v) for k, v in r.items()}
    return [list(r.items()) for r in map(norm, a)] == [list(r.items()) for r in map(norm, b)]


def test_campaign_results_are_each_runs_newest_row_in_the_spec_order_with_every_column(tmp_path):
    parts = tmp_path / "parts"
    parts.mkdir()
    # parts out of the spec's order, one of failed runs only (no metrics: nulls there), a run stored again later
    # (--retry-failed: its newer row wins), a metric that is NaN, a column only some parts have
    runner.write_parts(parts, [_outcome("r3", True, 0.3, **{"ISE(x)": 1.5, "max_tracking_error": math.nan}),
                               _outcome("r4", True, 0.4, **{"ISE(x)": 2.5, "max_tracking_error": 0.2})])
    time.sleep(0.002)
    runner.write_parts(parts, [_outcome("r1", False, 0.1), _outcome("r2", False, 0.2)])
    time.sleep(0.002)
    runner.write_parts(parts, [_outcome("r2", True, 0.25, **{"ISE(x)": 0.5, "max_tracking_error": 0.1, "extra": 7})])
    order = ["r1", "r2", "r3", "r4", "r5"]  # r5: never stored
    campaign = SimpleNamespace(cases=[SimpleNamespace(run_id=r) for r in order])
    results = runner.assemble(campaign, tmp_path)
    want, want_timings = _by_definition(parts, order)
    assert _same(pq.read_table(results).to_pylist(), want)
    assert pq.read_table(results).column_names == list(want[0])
    assert pq.read_table(results).schema.equals(pa.Table.from_pylist(want).schema)  # and the types the rows give
    assert pq.read_table(tmp_path / runner.TIMINGS).equals(pa.Table.from_pylist(want_timings))
    assert [r["completed"] for r in want] == [False, True, True, True] and want[1]["extra"] == 7


def test_no_stored_run_is_an_empty_results_file(tmp_path):
    runner.assemble(SimpleNamespace(cases=[SimpleNamespace(run_id="r1")]), tmp_path)
    assert pq.read_table(tmp_path / runner.RESULTS).num_rows == 0


@pytest.mark.parametrize("optimizer, sizes", [("cmaes", [2] + [8] * 6),  # a part a batch: 6 of 8 and the budget's last 2
                                               # the first two batches (out at once, before an evaluation has
                                               # said what it costs), then the rest asked ahead
                                               ("uniform", [8, 8, 34])])
def test_a_search_writes_a_part_a_group_of_batches_and_its_results_once_every_row_in_order(tmp_path, optimizer, sizes):
    dims = [Dimension("a", "plant.m_L", 0.0, 1.0), Dimension("b", "plant.l", 0.0, 1.0)]

    def evaluate(cases):
        return {c["run_id"]: {"run_id": c["run_id"], **c["values"], "robustness": 1.0 + c["unit"][0], "wall_s": 0.001}
                for c in cases}
    outcome = search(dims, optimizer, 3, evaluate, lambda rid, v: {"run_id": rid, "values": v, "parameters": {}}, 50, None,
                     tmp_path, "parts-a-batch", batch=8)
    parts = sorted((tmp_path / "parts").glob("*.parquet"))
    assert sorted(pq.read_table(p).num_rows for p in parts) == sizes
    rows = pq.read_table(tmp_path / "falsification.parquet").to_pylist()
    assert [r["index"] for r in rows] == list(range(50)) and rows == outcome.rows
    assert {i: r["run_id"] for i, r in read_parts(tmp_path / "parts").items()} == {r["index"]: r["run_id"] for r in rows}

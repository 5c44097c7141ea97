"""The search: an optimizer asks a batch of points, the batch runs in parallel (on the campaign's Dask machinery:
dispatch.py's retries and failure handling), each outcome is stored at once, the optimizer is told, until a point
falsifies a requirement (robustness < 0) or the budget (simulations, wall time) is spent.

Storage and resume: each batch's evaluations are a part, <out>/parts/<first index>+<count>-<stamp>.parquet (a row per
evaluation: its point of the unit cube u_*, the values, each requirement's robustness and verdict, wall time, worker;
older versions wrote <index>.parquet, one evaluation each, read the same), written as the batch ends; and
<out>/falsification.parquet is assembled once, when the search ends (stopped by an error too): nothing is rewritten
whole after every batch (benchmarks/scale_20k.py). The optimizers are deterministic for their seed and what they are
told, so a search killed half-way and started again asks the same points: a stored part whose point is the one asked is taken as
it is (not run again), and the search goes on exactly as the uninterrupted one would have.
"""

from __future__ import annotations

import hashlib
import json
import math
import time
from collections import deque
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import optimizers
from .spec import Dimension

RESULTS = "falsification.parquet"
PENALTY = 1e6  # told to the optimizer for a point without robustness (refused by the feasibility check)


@dataclass
class Outcome:
    """What a search found: every row in the order asked, the first falsifying index (None: none)."""

    rows: list[dict]
    falsified_at: int | None  # index (0-based) of the first evaluation with robustness < 0
    seconds: float
    reused: int = 0  # rows taken from a previous, interrupted run
    failures: dict = field(default_factory=dict)  # run id -> environment line (not stored)

    @property
    def simulations(self) -> int:
        return len(self.rows)

    @property
    def best(self) -> dict | None:
        scored = [r for r in self.rows if r.get("robustness") is not None and not math.isnan(r["robustness"])]
        return min(scored, key=lambda r: r["robustness"]) if scored else None


def run_id(identity: str, index: int, unit: np.ndarray) -> str:
    what = json.dumps({"search": identity, "index": index, "u": [float(x) for x in unit]}, sort_keys=True)
    return f"{index:06d}-" + hashlib.sha256(what.encode()).hexdigest()[:10]


def _stamp(path: Path) -> int:
    """When a part was written, from its name (<first>+<count>-<stamp>); an older version's <index>.parquet: 0."""
    _, _, stamp = path.stem.partition("-")
    return int(stamp, 16) if stamp else 0


def read_parts(folder: Path) -> dict[int, dict]:
    """The stored evaluations by index (an index stored twice, by a rerun with another spec: the newer part's row); a
    part that is not one is refused with its name (batch/parts.read_part)."""
    from ..batch.parts import part_paths, read_part

    out = {}
    paths = part_paths(folder)
    try:
        paths.sort(key=_stamp)
    except ValueError:  # a name this command did not write: read in name order, refused there if it is not a part
        pass
    for path in paths:
        for row in read_part(path, {"index": int, "run_id": str}):
            out[row["index"]] = row
    return out


def write_part(folder: Path, rows: list[dict]) -> None:
    """A batch's evaluations as one part (never replaced: a newer part of the same indices is a newer name)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    name = f"{rows[0]['index']:06d}+{len(rows)}-{time.time_ns():x}"
    tmp = folder / f".{name}.tmp"
    pq.write_table(pa.Table.from_pylist(rows), tmp)
    tmp.replace(folder / f"{name}.parquet")  # a part exists only once complete


def assemble(out: Path, rows: list[dict]) -> Path:
    import pyarrow as pa
    import pyarrow.parquet as pq

    keys = list(dict.fromkeys(k for r in rows for k in r))
    tmp = out / f".{RESULTS}.tmp"
    # column by column (what Table.from_pylist does with the rows), without a second dict a row
    pq.write_table(pa.table({k: [r.get(k) for r in rows] for k in keys}), tmp)
    tmp.replace(out / RESULTS)
    return out / RESULTS


def _told(row: dict) -> float:
    r = row.get("robustness")
    if r is None or math.isnan(r):
        return PENALTY
    return float(np.clip(r, -PENALTY, PENALTY))


def search(dimensions: list[Dimension], optimizer: str, seed: int, evaluate_batch: Callable[[list[dict]], dict[str, dict]],
           make_case: Callable[[str, dict], dict], simulations: int | None, seconds: float | None, out: Path | None,
           identity: str, batch: int | None = None, progress: Callable[[str], None] | None = None,
           stop_when_falsified: bool = True) -> Outcome:
    """Minimize the robustness over the dimensions. evaluate_batch(cases) -> {run_id: row} (rows of runs whose
    environment failed are missing); make_case(run_id, values) -> the case a worker gets. out: where parts and
    falsification.parquet go (None: kept in memory only)."""
    say = progress or (lambda _: None)
    parts = out / "parts" if out is not None else None
    if parts is not None:
        parts.mkdir(parents=True, exist_ok=True)
    stored = read_parts(parts) if parts is not None else {}
    opt = optimizers.make(optimizer, len(dimensions), seed, batch)
    rows: list[dict] = []
    started = time.perf_counter()
    falsified_at, reused, failures = None, 0, {}
    limit = simulations if simulations is not None else math.inf
    try:
        falsified_at, reused, failures = _loop(dimensions, optimizer, seed, evaluate_batch, make_case, limit, seconds,
                                               identity, opt, rows, stored, parts, say, started, stop_when_falsified)
    finally:  # once, at the end (an interrupted search's too): the batches done so far
        if out is not None and rows:
            assemble(out, rows)
    return Outcome(rows, falsified_at, time.perf_counter() - started, reused, failures)


AHEAD_SECONDS = 0.5  # an independent optimizer's batches are asked ahead until a worker has about this much work (a
# task costs a worker's event loop ~2.4 ms whatever it carries: 0.03-0.05 ms an evaluation less than at 0.25 s)
AHEAD_MOST = 256  # ... and at most this many points (what a search that falsifies early runs for nothing)
IN_FLIGHT = 2  # an independent optimizer's groups out at once: the one being judged and the next


def _group_size(opt, walls: list[float], threads: int) -> int:
    """How many points to ask before the first of them is told: the optimizer's batch, or for an optimizer whose asks
    do not depend on what it is told (uniform) enough batches to keep every worker busy for AHEAD_SECONDS (walls: the
    latest evaluations' wall seconds), so that a round trip to the workers, the part written and the client's turn are
    paid once a group, not once a batch (the rows are the same: the same points asked in the same order, told in the
    same order)."""
    if not opt.independent or not walls:  # the first batch measures what an evaluation costs
        return opt.batch
    ordered = sorted(walls[-64:])
    each = max(ordered[len(ordered) // 2], 1e-4)
    return int(min(AHEAD_MOST, max(opt.batch, threads * AHEAD_SECONDS / each)))


@dataclass
class _Group:
    """Batches asked together: each (the batch asked, the points of it run), the cases sent, the stored rows taken."""

    batches: list
    cases: list[dict]
    rows: dict[str, dict]
    end: int  # the index after its last point
    evaluated: object = None  # the future of evaluate_batch(cases) (None: nothing to run)


def _loop(dimensions, optimizer, seed, evaluate_batch, make_case, limit, seconds, identity, opt, rows: list[dict],
          stored: dict[int, dict], parts: Path | None, say, started: float, stop_when_falsified: bool):
    """The batches until the budget is spent, a point falsifies or an environment fails; rows grows as they end.
    Batches go to evaluate_batch a group at a time (_group_size); each is told and judged in the order asked, and the
    batches of a group after the one that ends the search are dropped. An independent optimizer has IN_FLIGHT groups
    out at once (asked and sent in order): a worker that ends its share of one starts on the next instead of waiting
    for the other workers' shares and the client's turn; the groups out when the search ends are dropped whole.
    (falsified_at, reused, failures)."""
    from .space import values_at

    threads = max(1, int(getattr(evaluate_batch, "threads", 1)))
    walls: list[float] = []
    falsified_at, reused, failures = None, 0, {}

    def more(at: int) -> bool:
        return at < limit and (seconds is None or time.perf_counter() - started < seconds)

    def ask(at: int) -> _Group:
        group = _Group([], [], {}, at)
        size = _group_size(opt, walls, threads)
        while group.end < limit and (not group.batches or group.end - at + opt.batch <= size):
            whole = opt.ask()
            asked = whole[:int(min(len(whole), limit - group.end))]  # the budget's last batch may be cut: never told
            group.batches.append((whole, asked))
            for j, unit in enumerate(asked):
                index = group.end + j
                rid = run_id(identity, index, unit)
                old = stored.get(index)
                if old is not None and old["run_id"] == rid:
                    group.rows[rid] = old
                    continue
                case = make_case(rid, values_at(dimensions, unit))
                case["unit"] = [float(x) for x in unit]
                case["index"] = index
                group.cases.append(case)
            group.end += len(asked)
        if group.cases:  # on the sender's thread while this one judges the group before (an independent optimizer)
            group.evaluated = sender.submit(evaluate_batch, group.cases) if sender else _done(evaluate_batch(group.cases))
        return group

    sender = ThreadPoolExecutor(IN_FLIGHT, thread_name_prefix="search-batches") if opt.independent else None
    out: deque[_Group] = deque()  # the groups sent, in the order asked
    ended = False
    try:
        group = ask(len(rows)) if more(len(rows)) else None
        while group is not None:
            while opt.independent and len(out) < IN_FLIGHT - 1 and more((out[-1] if out else group).end):
                out.append(ask((out[-1] if out else group).end))
            got = group.evaluated.result() if group.evaluated is not None else {}
            fresh = {}
            for case in group.cases:
                row = got.get(case["run_id"])
                if row is None:
                    continue
                row = {"index": case["index"], "optimizer": optimizer, "optimizer_seed": seed, **row,
                       **{f"u_{d.name}": u for d, u in zip(dimensions, case["unit"])}}
                row["run_id"] = case["run_id"]
                group.rows[case["run_id"]] = fresh[case["run_id"]] = row
                walls.append(float(row.get("wall_s") or 0.0))
            kept, done = [], False
            for whole, asked in group.batches:
                ids = [run_id(identity, len(rows) + j, unit) for j, unit in enumerate(asked)]
                missing = [rid for rid in ids if rid not in group.rows]
                if missing:  # the environment failed for these (after the dispatcher's retries): the search cannot go on
                    failures.update({rid: "its environment failed" for rid in missing})
                    kept += [fresh[rid] for rid in ids if rid in fresh]  # stored: a rerun takes them as they are
                    done = True
                    break
                ordered = [group.rows[rid] for rid in ids]
                reused += sum(1 for rid in ids if rid not in fresh)
                if len(asked) == len(whole):
                    opt.tell(asked, [_told(r) for r in ordered])
                for r in ordered:
                    if falsified_at is None and r.get("robustness") is not None and r["robustness"] < 0:
                        falsified_at = int(r["index"])
                rows.extend(ordered)
                kept += [fresh[rid] for rid in ids if rid in fresh]
                if stop_when_falsified and falsified_at is not None:
                    done = True
                    break
            if parts is not None and kept:
                write_part(parts, kept)
            best = min((_told(r) for r in rows), default=math.nan)
            from ..evidence.falsification_page import simulations  # the report's words: "1 simulation"

            say(f"  {simulations(len(rows))}, best robustness {best:.6g}, {time.perf_counter() - started:.0f} s")
            if done:
                break  # the groups out are dropped: the sender waits for their evaluations to end
            group = out.popleft() if out else (ask(len(rows)) if more(len(rows)) else None)
        ended = True
    finally:  # a group still out is dropped: waited for when the search ended, left to the closing client on an error
        if sender is not None:
            sender.shutdown(wait=ended, cancel_futures=True)
    return falsified_at, reused, failures


def _done(value) -> Future:
    """An evaluation already done, as a future."""
    future = Future()
    future.set_result(value)
    return future

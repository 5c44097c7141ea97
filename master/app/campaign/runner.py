"""Campaigns on Dask: every case of a spec runs as a task; each finished run is saved at once, so a rerun skips it.

Results: <out>/results.parquet, one row per run (run id, controller, seed, the varied values, the
metrics, completed / diverged / when / error line), ordered as the spec lists the runs, and
<out>/timings.parquet (wall and set-up time of each run, which differ between machines). Each
finished run is first written to <out>/parts/<run id>.parquet; `results.parquet` is assembled
from the parts, so a campaign killed half-way and started again runs only what is missing.
Runs execute on a LocalCluster sized to the machine, or on an existing Dask scheduler. Workers
must see the FMU folder (and the log folder, with logs kept) at the same paths.
"""

from __future__ import annotations

import os
import sys
import time
from dataclasses import asdict
from pathlib import Path

from .spec import Campaign, load

RESULTS, TIMINGS = "results.parquet", "timings.parquet"


def _write_part(folder: Path, result: dict) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    row = dict(result["row"])
    row["_wall"], row["_setup"], row["_sim_time"] = result["wall"], result["setup"], result["sim_time"]
    tmp = folder / f".{row['run_id']}.tmp"
    pq.write_table(pa.Table.from_pylist([row]), tmp)
    tmp.replace(folder / f"{row['run_id']}.parquet")  # a part exists only once complete


def assemble(campaign: Campaign, out: Path) -> Path:
    """results.parquet and timings.parquet from the parts, in the spec's order of runs."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    parts = out / "parts"
    rows = []
    for case in campaign.cases:
        path = parts / f"{case.run_id}.parquet"
        if path.is_file():
            rows.append(pq.read_table(path).to_pylist()[0])
    results = [{k: v for k, v in r.items() if not k.startswith("_")} for r in rows]
    keys = list(dict.fromkeys(k for r in results for k in r))  # failed runs lack metrics: fill with null
    pq.write_table(pa.Table.from_pylist([{k: r.get(k) for k in keys} for r in results]), out / RESULTS)
    pq.write_table(pa.Table.from_pylist([{"run_id": r["run_id"], "wall_s": r["_wall"], "setup_s": r["_setup"],
                                          "sim_time": r["_sim_time"]} for r in rows]), out / TIMINGS)
    return out / RESULTS


def _client(scheduler: str | None, workers: int | None):
    from dask.distributed import Client, LocalCluster

    if scheduler:
        return Client(scheduler, timeout="20s"), None
    n = workers or os.cpu_count() or 1
    cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=":0", silence_logs=40)
    return Client(cluster), cluster


def run(spec: Path, out: Path | None = None, scheduler: str | None = None, workers: int | None = None, fmus: Path = Path("fmus"),
        progress=None) -> tuple[Path, dict]:
    """Run what is missing of a campaign; returns results.parquet and counts (total, skipped, ran, failed)."""
    from dask.distributed import as_completed

    from ..fmus import build_all
    from .run_case import error_row, run_case

    campaign = load(spec)
    out = Path(out) if out else Path("runs") / "campaigns" / campaign.name
    (out / "parts").mkdir(parents=True, exist_ok=True)
    (out / f"spec{Path(spec).suffix}").write_bytes(Path(spec).read_bytes())  # the report's rerun commands read it
    logs = out / "logs" if campaign.keep_logs else None
    if logs:
        logs.mkdir(exist_ok=True)
    done = {p.stem for p in (out / "parts").glob("*.parquet")}
    todo = [c for c in campaign.cases if c.run_id not in done]
    say = progress or (lambda text: print(text, file=sys.stderr))
    say(f"campaign {campaign.name}: {len(campaign.cases)} runs, {len(campaign.cases) - len(todo)} already done, {len(todo)} to run")
    counts = {"total": len(campaign.cases), "skipped": len(campaign.cases) - len(todo), "ran": 0, "failed": 0}
    if todo:
        build_all(fmus, progress=say)
        os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # the workers' numpy: one thread each
        base = {"scenario": campaign.scenario, "trajectory": campaign.trajectory, "stop_time": campaign.stop_time,
                "gusts": campaign.gusts, "keep_metrics": list(campaign.keep_metrics), "faults": campaign.faults}
        client, cluster = _client(scheduler, workers)
        try:
            cases = {}  # future -> case: the futures must stay referenced, or Dask forgets their tasks
            for c in todo:
                future = client.submit(run_case, base, asdict(c), str(Path(fmus).resolve()), str(logs.resolve()) if logs else None,
                                       key=f"run-{c.run_id}", pure=False)
                cases[future] = c
            started = time.perf_counter()
            for k, future in enumerate(as_completed(list(cases)), start=1):
                try:
                    result = future.result()
                except Exception as err:  # the worker died (a crashing FMU): the run is a row with that line
                    result = {"row": error_row(asdict(cases[future]), f"worker lost: {type(err).__name__}: {err}"),
                              "wall": 0.0, "setup": 0.0, "sim_time": 0.0}
                _write_part(out / "parts", result)
                counts["ran"] += 1
                counts["failed"] += not result["row"]["completed"]
                elapsed = time.perf_counter() - started
                eta = elapsed / k * (len(todo) - k)
                say(f"  {k}/{len(todo)} runs ({counts['failed']} failed), {elapsed:.0f} s, about {eta:.0f} s left")
            counts["seconds"] = time.perf_counter() - started  # submitting to the last result: no cluster start or stop
        finally:
            client.close()
            if cluster is not None:
                cluster.close()
    return assemble(campaign, out), counts

"""Campaigns on Dask: the cases of a spec run as tasks (several a task: dispatch.py); each task's outcomes are saved
at once, so a rerun skips them.

Results: <out>/results.parquet, one row per run (run id, controller, seed, the varied values, the
metrics, completed / diverged / when / error line), ordered as the spec lists the runs, and
<out>/timings.parquet (wall and set-up time of each run, which differ between machines). A task's
outcomes are first written to a part, <out>/parts/<first run id>+<count>-<unique>.parquet (write_parts);
`results.parquet` is assembled from the parts (a run's newest row), so a campaign stopped half-way
(killed, or its scheduler gone) and started again runs only what is missing. Only outcomes are
parts: a run whose environment failed, or whose future was cancelled, is not (dispatch.py). Runs
execute on a LocalCluster on the loopback interface, sized to the machine, or on an existing Dask
scheduler, checked before anything is built or written (cluster.py). An existing cluster's workers get the FMUs
from the client (shipping.py); they must see the log folder (with logs kept) at the same path. Dask's log goes to
<out>/campaign.log (logs.py).
"""

from __future__ import annotations

import os
import sys
import time
from dataclasses import asdict, dataclass, replace
from functools import partial
from pathlib import Path

from ..batch.errors import CampaignIncomplete
from ..batch.logs import LOG, LOGGER, campaign_log
from ..loop.defaults import FMU_DIR, WORKER_TIMEOUT
from .spec import Campaign, CampaignBase, Case, SpecError, load

RESULTS, TIMINGS = "results.parquet", "timings.parquet"


@dataclass
class Options:
    """How a campaign runs: where, how patiently, what again."""

    scheduler: str | None = None  # an existing scheduler's address; None: a local cluster
    workers: int | None = None  # the local cluster's size; with a scheduler: how many workers to wait for
    connect_timeout: float = 5.0  # s for the scheduler to answer
    worker_timeout: float = WORKER_TIMEOUT  # s to wait for workers (before the runs, and when all are gone)
    retries: int = 2  # further tries of a run whose environment failed
    retry_failed: bool = False  # run again the stored runs that failed
    verbose: bool = False  # Dask's log on the terminal too


def write_part(folder: Path, result: dict) -> None:
    """One outcome as a part of its own."""
    write_parts(folder, [result])


def write_parts(folder: Path, results: list[dict]) -> None:
    """Outcomes (a task's) as one part, <first run id>+<count>-<unique>.parquet: a part is never replaced, so a run
    stored again (--retry-failed) is a newer row in a newer part; the newest row of a run is its outcome."""
    import uuid

    import pyarrow as pa
    import pyarrow.parquet as pq

    at = time.time_ns()
    rows = []
    for result in results:
        row = dict(result["row"])
        row["_wall"], row["_setup"], row["_sim_time"] = result["wall"], result["setup"], result["sim_time"]
        row["_stored_at"] = at
        rows.append(row)
    name = f"{rows[0]['run_id']}+{len(rows)}-{uuid.uuid4().hex[:8]}"
    tmp = folder / f".{name}.tmp"
    pq.write_table(pa.Table.from_pylist(rows), tmp)
    tmp.replace(folder / f"{name}.parquet")  # a part exists only once complete


def _warm_writer() -> None:
    """The first Parquet write imports pandas (pyarrow's metadata): a quarter of a second, paid here rather than by
    the first outcome, while the workers wait for their next run."""
    import io

    import pyarrow as pa
    import pyarrow.parquet as pq

    pq.write_table(pa.Table.from_pylist([{"run_id": "", "_wall": 0.0}]), io.BytesIO())


def _newest_rows(parts: Path) -> dict[str, tuple[bool, int, int]]:
    """Where each stored run's newest row is: (its completed, its part's number in sorted order, its row there); rows
    of older versions' parts (one run a part, no _stored_at) count as oldest. Every part is checked
    (batch/parts.read_part: one that is not a part is refused with its name), none kept: bounded memory."""
    from ..batch.parts import part_paths, read_part

    newest: dict[str, tuple[bool, int, int, int]] = {}
    for number, path in enumerate(part_paths(parts)):
        for at, row in enumerate(read_part(path, {"run_id": str, "completed": bool})):
            old = newest.get(row["run_id"])
            stored_at = row.get("_stored_at") or 0
            if old is None or stored_at >= old[3]:
                newest[row["run_id"]] = (row["completed"], number, at, stored_at)
    return {rid: (completed, number, at) for rid, (completed, number, at, _) in newest.items()}


def _stored(parts: Path, cases: list[Case], failed_too: bool) -> set[str]:
    """The run ids whose outcome is stored; with failed_too, only those that completed (the failed ones run again)."""
    ids = {c.run_id for c in cases}
    return {rid for rid, (completed, _, _) in _newest_rows(parts).items() if rid in ids and (not failed_too or completed)}


def assemble(campaign: Campaign, out: Path) -> Path:
    """results.parquet and timings.parquet from the parts, in the spec's order of runs: each run's newest row, with
    the columns in the order the rows bring them (a failed run lacks the metrics: null there). Built as Arrow tables
    (a part's columns, not a dict a row), so 20,000 runs cost the client megabytes, not a row object each."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    paths = sorted((out / "parts").glob("*.parquet")) if (out / "parts").is_dir() else []
    newest = _newest_rows(out / "parts")
    chosen = [newest[case.run_id] for case in campaign.cases if case.run_id in newest]
    used = list(dict.fromkeys(number for _, number, _ in chosen))  # the parts, in the order their first row comes
    tables, offsets, total = {}, {}, 0
    for number in used:
        tables[number] = pq.read_table(paths[number])
        offsets[number], total = total, total + tables[number].num_rows
    if not used:
        pq.write_table(pa.table({}), out / RESULTS)
        pq.write_table(pa.table({}), out / TIMINGS)
        return out / RESULTS
    keys = list(dict.fromkeys(k for number in used for k in tables[number].column_names))
    whole = pa.concat_tables([tables[n] for n in used], promote_options="permissive")
    whole = whole.take(pa.array([offsets[number] + at for _, number, at in chosen], type=pa.int64()))
    del tables
    results = whole.select([k for k in keys if not k.startswith("_")])
    pq.write_table(results, out / RESULTS)
    pq.write_table(pa.table({"run_id": whole["run_id"], "wall_s": whole["_wall"], "setup_s": whole["_setup"],
                             "sim_time": whole["_sim_time"]}), out / TIMINGS)
    return out / RESULTS


def held(results: Path) -> dict[str, int]:
    """What a results file holds: rows (stored), completed, failed (diverged among them)."""
    import pyarrow.parquet as pq

    table = pq.read_table(results)
    completed = table["completed"].to_pylist() if "completed" in table.column_names else []
    diverged = table["diverged"].to_pylist() if completed else []
    return {"stored": len(completed), "completed": sum(completed), "failed": len(completed) - sum(completed),
            "diverged": sum(bool(d) for d in diverged)}


def _prepare_workers(client, base: CampaignBase, case: Case, fmu_dir: str, shipped=None) -> list:
    """A task on each worker there is now that instantiates the first case's system (worker.prepare; with shipped FMUs,
    from its machine's copy: shipping.py): their futures. The workers do it while this process checks the cases'
    feasibility, rather than in their first run."""
    from ..batch.shipping import prepare_shipped
    from ..batch.worker import prepare

    try:
        workers = sorted(client.scheduler_info()["workers"])
    except Exception:  # the dispatch says what is wrong with the scheduler
        return []
    task, args = (prepare, (base, asdict(case), fmu_dir)) if shipped is None else (prepare_shipped, (shipped, base, asdict(case)))
    return [client.submit(task, *args, workers=[w], allow_other_workers=False, pure=False,
                          key=f"prepare-{k}-{time.time_ns()}") for k, w in enumerate(workers)]


def run(spec: Path, out: Path | None = None, fmus: Path = FMU_DIR, progress=None, **options) -> tuple[Path, dict]:
    """Run what is missing of a campaign (options: the fields of Options); returns results.parquet and counts: total
    (the spec's runs), what the results hold (stored, completed, failed, diverged), skipped (stored before), ran
    (stored now), retried, seconds. CampaignIncomplete (with .counts) when runs are still missing at the end (the
    results hold the others); ClusterError, before anything is built or written, when the cluster cannot take it."""
    from ..batch.address import parse
    from ..batch.cluster import connect, local_cluster
    from ..batch.dispatch import Dispatch, Policy
    from ..output_folder import writable_folder
    from .report import ORIGIN

    opts = Options(**options)
    scheduler, workers = opts.scheduler, opts.workers
    campaign = load(spec)
    out = writable_folder(Path(out) if out else Path("runs") / "campaigns" / campaign.name, "--out")
    done = _stored(out / "parts", campaign.cases, opts.retry_failed)
    todo = [c for c in campaign.cases if c.run_id not in done]
    say = progress or (lambda text: print(text, file=sys.stderr))
    if campaign.wrapped:  # said as run and b2b say it
        from ..wrap.class_fmu import wrapped_line

        for source, fmu in campaign.wrapped:
            say(f"base.controllers {wrapped_line(source, fmu)}")
    clock = time.perf_counter()  # the campaign's clock, start-up included: its progress lines' elapsed time
    counts = {"total": len(campaign.cases), "skipped": len(campaign.cases) - len(todo), "ran": 0, "retried": 0}
    incomplete = None
    import tempfile

    import dask

    # Dask's workers keep a scratch folder with lock files (dask-scratch-space/{global,purge}.lock) in its
    # temporary-directory: a folder this campaign owns and removes, not $TMPDIR
    with (campaign_log(opts.verbose) as log, tempfile.TemporaryDirectory(prefix="tiltload-campaign-") as scratch,
          dask.config.set({"temporary-directory": scratch,
                           # a worker holds its task and the next (ceil(1.1 x 1 thread) = 2): it starts the next without
                           # a round trip to the scheduler, and the scheduler hands the rest to whichever worker is free
                           # (with every task on a worker at once, as before chunks, the ends of the queues differed by
                           # a chunk until work stealing moved it: benchmarks/campaign_native.py)
                           "distributed.scheduler.worker-saturation": 1.1})):
        client = cluster = None
        prepared: list = []
        if scheduler is not None:
            parse(scheduler)  # a malformed address is refused even with nothing to run
            if todo:
                client = connect(scheduler, workers or 1, opts.connect_timeout, opts.worker_timeout)
        try:
            (out / "parts").mkdir(parents=True, exist_ok=True)
            log.to_file(out / LOG)
            LOGGER.info("campaign %s (%s): %d runs, %d stored, %d to run", campaign.name, Path(spec).resolve(),
                        len(campaign.cases), len(campaign.cases) - len(todo), len(todo))
            (out / f"spec{Path(spec).suffix}").write_bytes(Path(spec).read_bytes())  # the report's rerun commands read it
            (out / ORIGIN).write_text(f"{Path(spec).resolve()}\n")  # and find its relative paths (controllers) from there
            logs = out / "logs" if campaign.keep_logs else None
            if logs:
                logs.mkdir(exist_ok=True)
            say(f"campaign {campaign.name}: {len(campaign.cases)} runs, {len(campaign.cases) - len(todo)} already done, "
                f"{len(todo)} to run")
            if todo:
                from ..batch.shipping import WithShippedFmus, ship
                from ..batch.worker import feasibility_verdicts
                from ..loop.fmus import build_all, loop_recipes  # these import the controller's design tools: seconds, so only now
                from .fmus_record import record_fmus
                from .run_case import run_case

                build_all(fmus, progress=say)
                if campaign.snapshot is not None:
                    _check_branches(campaign, Path(fmus).resolve())
                else:
                    _check_controllers(campaign, todo, Path(fmus).resolve())
                record_fmus(campaign, Path(fmus).resolve(), out)  # what the report names as the FMUs run
                os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # the workers' numpy: one thread each
                if client is None:
                    say(f"starting a local Dask cluster ({workers or os.cpu_count()} workers)")  # seconds: said
                    client, cluster = local_cluster(workers, opts.verbose, Path(scratch))
                    say(f"  cluster ready, {time.perf_counter() - clock:.0f} s")
                where = str(parse(scheduler)) if cluster is None else f"{cluster.scheduler_address} (the local cluster's)"
                base = campaign.base()
                shared, shipped = {}, None
                if cluster is None:  # an existing cluster's workers need no copy of the FMUs: shipped (shipping.py)
                    shipped = ship(client, Path(fmus), [r.fmu_name for r in loop_recipes()],
                                   [c.controller for c in todo if c.controller not in ("dlqr", "mixed")])
                if campaign.snapshot is None:  # checked once here, not once per worker (seconds each), while the
                    # workers instantiate the first case's system
                    prepared = _prepare_workers(client, base, todo[0], str(Path(fmus).resolve()), shipped)
                    # the cases read only, not copied (asdict's deep copies were 47 us a run)
                    base = replace(base, feasibility=feasibility_verdicts(base, [vars(c) for c in todo], str(Path(fmus).resolve())))
                task = partial(run_case, base, fmu_dir=str(Path(fmus).resolve()), log_dir=str(logs.resolve()) if logs else None)
                if shipped is not None:
                    task = WithShippedFmus(task, shipped)
                if campaign.snapshot is not None:  # to every worker once, not with every run
                    shared["snapshot"] = client.scatter(campaign.snapshot.read_bytes(), broadcast=True, hash=False)
                _warm_writer()
                dispatch = Dispatch(client, task, partial(write_part, out / "parts"), where, len(campaign.cases),
                                    len(campaign.cases) - len(todo),
                                    Policy(opts.retries, opts.worker_timeout, opts.connect_timeout), say, shared,
                                    chunked=True, store_many=partial(write_parts, out / "parts"), started=clock)
                started = time.perf_counter()
                try:
                    dispatch.run(todo)
                    if dispatch.failures:
                        incomplete = _not_run(dispatch.failures, len(todo), opts.retries, log.path)
                except CampaignIncomplete as err:
                    incomplete = CampaignIncomplete(f"{err}{_see(log.path)}")
                counts["seconds"] = time.perf_counter() - started  # throughput: submitting to the last result (the progress
                # lines' clock is the campaign's, the cluster's start included)
                counts["ran"], counts["retried"] = dispatch.stored, dispatch.retried
        finally:
            if prepared:  # one whose worker died would wait for it for ever
                try:
                    client.cancel(prepared)
                except Exception:
                    pass
            if client is not None:
                client.close()
            if cluster is not None:
                cluster.close()
    results = assemble(campaign, out)
    counts.update(held(results))
    if incomplete is not None:
        incomplete.counts = counts
        raise incomplete
    return results, counts


def _check_branches(campaign: Campaign, fmus: Path) -> None:
    """Before any run: the snapshot continues on these FMUs (their build), with the cases' faults and tunable
    parameters (a fixed one is refused), as a worker will run them (the first case: all set the same names)."""
    from ...engine import snapshot
    from ...engine.errors import DescriptionError
    from ...engine.execution import Execution
    from ..case.system import branch_system

    snap = snapshot.read(campaign.snapshot)
    for case in campaign.cases[:1]:
        try:
            system, branch = branch_system(fmus, snap, campaign.faults, case.parameters, case.controller)
            snapshot.check(Execution(system, []), branch)
        except DescriptionError as err:
            raise SpecError(f"{campaign.source}: base.snapshot: {err}") from None


def _check_controllers(campaign: Campaign, todo: list[Case], fmus: Path) -> None:
    """Each user's controller file described into its first case's system before any cluster starts, as a worker will:
    one that is not an FMU (or not one of a tick's period) is the spec's error, not a failure of each of its runs."""
    from ...engine.errors import DescriptionError
    from ..case.system import case_system
    from ..loop.defaults import OUR_CONTROLLERS

    firsts = {c.controller: c for c in reversed(todo) if c.controller not in OUR_CONTROLLERS}
    for controller, case in firsts.items():
        try:
            case_system(fmus, campaign.base(), controller, case.seed, case.parameters)
        except DescriptionError as err:
            raise SpecError(f"{campaign.source}: base.controllers: {err}") from None


def _see(log: Path | None) -> str:
    return f" (details: {log})" if log is not None else ""


def _not_run(failures: dict[str, str], tried: int, retries: int, log: Path | None) -> CampaignIncomplete:
    lines = list(dict.fromkeys(failures.values()))
    more = f"; and {len(lines) - 1} other reason{'s' if len(lines) > 2 else ''}" if len(lines) > 1 else ""
    return CampaignIncomplete(f"{len(failures)} of {tried} runs failed for their environment, not for themselves, "
                              f"up to {retries + 1} tries each ({lines[0]}{more}); nothing of them is stored: fix it and rerun "
                              f"the same command to finish{_see(log)}")


"""`tiltload falsify SPEC`: the search of a spec on a Dask cluster (a local one on the loopback interface, or an existing
scheduler, as campaigns run: batch/cluster.py), its evaluations dispatched with the campaign's retries and failure
handling (batch/dispatch.py), its results and report written to the output folder."""

from __future__ import annotations

import hashlib
import json
import os
import sys
import tempfile
from dataclasses import replace
from functools import partial
from pathlib import Path

from ..batch.errors import CampaignIncomplete
from ..case.case_set import Case
from ..case.spec_file import SpecError
from ..loop.defaults import FMU_DIR, WORKER_TIMEOUT
from .search import Outcome, search
from .spec import Falsification, SearchBase, load

LOG = "falsify.log"


def identity(spec: Falsification, early_stop: bool = True) -> str:
    """What the stored evaluations depend on: a rerun with another spec (or early stop) does not take them. Branching
    is not in it: a branch's outcome is the whole run's, bit for bit (checked before it is used: branching.choose)."""
    what = {"name": spec.name, "early_stop": early_stop, "optimizer": spec.optimizer, "seed": spec.seed, "batch": spec.batch,
            "loop": [spec.scenario, str(spec.flight.trajectory.label), spec.controller, spec.loop_seed, spec.stop_time,
                     spec.gusts, sorted(spec.parameters.items()), spec.faults, dict(spec.flight.wind), spec.gust],
            "requirements": [r.formula for r in spec.requirements],
            "dimensions": [[d.name, d.target, d.low, d.high, d.integer] for d in spec.dimensions]}
    return hashlib.sha256(json.dumps(what, sort_keys=True, default=str).encode()).hexdigest()[:16]


def check_names(spec: Falsification, fmus: Path) -> None:
    """Before any run, against the built FMUs: each requirement's signal is an output of its instance, each searched
    instance.name a parameter of it."""
    from ...engine.fmi.model_description import read_fmu
    from ..case.system import case_system

    system = case_system(fmus, spec.base(), spec.controller, spec.loop_seed, dict(spec.parameters))
    outputs, parameters = {}, {}
    for inst in system.instances:
        md = read_fmu(inst.fmu, inst.name)
        outputs[inst.name] = {v.name for v in md.modelVariables if v.causality == "output"}
        parameters[inst.name] = {v.name for v in md.modelVariables if v.causality == "parameter"}
    for d in spec.dimensions:
        instance, _, name = d.target.partition(".")
        if instance in parameters and name not in parameters[instance]:
            import difflib

            close = difflib.get_close_matches(name, sorted(parameters[instance]), n=3)
            hint = f" (did you mean {', '.join(instance + '.' + c for c in close)}?)" if close else ""
            raise SpecError(f"{spec.source}: search: {d.target} is not a parameter of {instance}{hint}")
    for s in spec.signals:
        instance, _, variable = s.partition(".")
        if variable not in outputs.get(instance, set()):
            import difflib

            close = difflib.get_close_matches(variable, sorted(outputs.get(instance, ())), n=3)
            hint = f" (did you mean {', '.join(instance + '.' + c for c in close)}?)" if close else ""
            raise SpecError(f"{spec.source}: requirements: {s} is not an output of {instance}{hint}")


def cluster_batch(client, where: str, base: SearchBase, fmus: Path, retries: int = 2, ship: bool = False):
    """evaluate_batch for search(): the cases through batch/dispatch.py on the client's cluster. ship: the workers
    get the FMUs from this client (an existing cluster's: batch/shipping.py), registered once for every batch."""
    from ..batch.dispatch import Dispatch, Policy, cluster_threads, even_chunks
    from .evaluate import evaluate

    task = partial(evaluate, base, fmu_dir=str(fmus.resolve()))
    if ship:
        from ..batch import shipping
        from ..loop.fmus import loop_recipes

        shipped = shipping.ship(client, fmus, [r.fmu_name for r in loop_recipes()],
                                [base.controller] if base.controller not in ("dlqr", "mixed") else [])
        task = shipping.WithShippedFmus(task, shipped)

    def run(cases: list[dict]) -> dict[str, dict]:
        got: dict[str, dict] = {}
        # the batch as one task a worker: a task costs a worker about 2.4 ms of Dask's messages (docs/throughput.md)
        dispatch = Dispatch(client, task, lambda result: got.__setitem__(result["row"]["run_id"], result["row"]), where,
                            len(cases), 0, Policy(retries=retries), chunked=True, sizes=even_chunks)
        dispatch.run([Case(c["run_id"], base.controller, base.seed, c["values"], c["parameters"]) for c in cases])
        return got
    run.threads = cluster_threads(client)  # search.py asks an independent optimizer's batches ahead for this many
    return run


def cheaper_base(spec: Falsification, fmus: Path, early_stop: bool = True, branch: str = "auto") -> tuple[SearchBase, list[str]]:
    """The workers' base with the cheaper evaluations it can have (evaluate.py): early stop, and branching from a
    snapshot when the searched inputs all act late and (auto) it measured faster here; the lines that say what."""
    from ..loop.thesis import TICK
    from .branching import branch_tick, choose, with_branch

    base = replace(spec.base(), early_stop=early_stop)
    notes = ["early stop at the first decided violation: " + ("on" if early_stop else "off")]
    ticks = branch_tick(spec.dimensions, base.faults, TICK) if branch != "off" else None
    if branch == "off":
        notes.append("branching from a snapshot: off")
    elif ticks is None:
        notes.append("branching from a snapshot: not possible (a searched input may act from the start)")
    elif branch == "on":
        notes.append(f"branching from a snapshot at t = {ticks * TICK:.3f} s: on")
        base = with_branch(base, ticks)
    else:
        use, line = choose(base, spec.dimensions, fmus, ticks)
        notes.append(line)
        if use:
            base = with_branch(base, ticks)
    return base, notes


def make_case(base: SearchBase):
    from .space import case_parameters

    def make(rid: str, values: dict) -> dict:
        return {"run_id": rid, "values": values, "parameters": case_parameters(base, values)}
    return make


def falsify(spec_path: Path, out: Path | None = None, fmus: Path = FMU_DIR, optimizer: str | None = None,
            seed: int | None = None, simulations: int | None = None, seconds: float | None = None,
            scheduler: str | None = None, workers: int | None = None, client=None, progress=None,
            write_report: bool = True, early_stop: bool = True, branch: str = "auto", neighbourhood: bool = False,
            fraction: float = 0.1, points: int | None = None, stop_when_falsified: bool = True,
            ) -> tuple[Falsification, Outcome, Path]:
    """Run (or finish) a falsification; returns the spec, what the search found and the output folder. client: an
    existing Dask client to run on (benchmarks); else a local cluster or the scheduler's. early_stop: each evaluation
    stops at its first decided violation; branch: auto (measured: cheaper_base), on or off; neighbourhood: then run the
    grid around the best case (neighbourhood.py: ±fraction of each range, points values each); stop_when_falsified=False:
    the whole budget even past a falsification (benchmarks/search_throughput.py)."""
    from ..batch.cluster import connect, local_cluster
    from ..batch.logs import campaign_log
    from ..loop.fmus import build_all
    from ..output_folder import writable_folder
    from .search import read_parts

    spec = load(spec_path)
    changes = {k: v for k, v in (("optimizer", optimizer), ("seed", seed), ("simulations", simulations),
                                 ("seconds", seconds)) if v is not None}
    spec = replace(spec, **changes)
    out = writable_folder(Path(out) if out else Path("runs") / "falsify" / f"{spec.name}-{spec.optimizer}-{spec.seed}",
                          "--out")
    read_parts(out / "parts")  # what a rerun goes on from: a part that is not one is refused now, before any cluster
    say = progress or (lambda text: print(text, file=sys.stderr))
    if spec.wrapped is not None:  # said as run and b2b say it
        from ..wrap.class_fmu import wrapped_line

        say(f"base.controller {wrapped_line(spec.wrapped, spec.controller)}")
    fmus = Path(fmus).resolve()
    build_all(fmus, progress=say)
    check_names(spec, fmus)
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    cluster = None
    own = client is None
    where = scheduler or "the local cluster"
    out.mkdir(parents=True, exist_ok=True)
    # Dask's records (a worker's traceback, a retry's cause) go to <out>/falsify.log, as a campaign's to campaign.log,
    # and the workers' scratch folder (its lock files) is one this search owns and removes, not $TMPDIR's
    with campaign_log(False) as log, tempfile.TemporaryDirectory(prefix="tiltload-falsify-") as scratch:
        log.to_file(out / LOG)
        try:
            if own:
                if scheduler is not None:
                    client = connect(scheduler, workers or 1, 5.0, WORKER_TIMEOUT)
                else:
                    client, cluster = local_cluster(workers, scratch=Path(scratch))
                    where = f"{cluster.scheduler_address} (the local cluster's)"
            (out / f"spec{Path(spec_path).suffix}").write_bytes(Path(spec_path).read_bytes())
            base, notes = cheaper_base(spec, fmus, early_stop, branch)  # said once, in the summary (not here too)
            batch = cluster_batch(client, where, base, fmus, ship=own and scheduler is not None)
            outcome = search(spec.dimensions, spec.optimizer, spec.seed, batch, make_case(base), spec.simulations,
                             spec.seconds, out, identity(spec, early_stop), spec.batch, say, stop_when_falsified)
            if neighbourhood and outcome.best is not None and not outcome.failures:
                from . import neighbourhood as nb

                say(nb.run(spec, outcome.best, batch, make_case(base), out, fraction, points))
        finally:
            if own and client is not None:
                client.close()
            if cluster is not None:
                cluster.close()
    if write_report:
        from .report import write

        write(spec, outcome, out, fmus, notes)
    if outcome.failures:
        raise CampaignIncomplete(f"{len(outcome.failures)} evaluations failed for their environment, not for themselves "
                                 f"(details: {out / LOG}); what was stored stays: rerun the same command to go on")
    return spec, outcome, out

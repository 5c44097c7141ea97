"""`tiltload b2b`: a case list run twice, with a reference and a candidate (two controllers, two builds of the FMUs, a
parameter changed), compared signal by signal in tolerance tubes (docs/back_to_back.md): a table, a case a row.

A side is what differs between the two: the FMU folder, the controller (dlqr, mixed or a controller FMU; by default
the case's), --set values and the controller's stage (docs/mil_sil_pil.md): sil, its FMU in this process; mil, the
thesis's controller as its numpy reference in a Python process (mil.py); pil, the FMU's aarch64 binary on tl_serve under
qemu-user (pil.py). A mil or pil controller is the remote instance of the run: the master is the same for all three.
Both sides of a case run the same scenario, trajectory, seed and stop time; the runs go through one ExecutionPool (a
case after the first restarts its side's execution: fmi2Reset and the case's parameters, as a campaign's runs do).
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...command_line.argument_types import MAX_RUN
from ...engine.errors import DescriptionError
from ...engine.observers import Observer
from ...engine.user_files import UserFileError, check_values, read_document, schema_problem
from ..loop.defaults import FMU_DIR, SEED
from ..user_error import UserError
from .signal_compare import SignalRow, Tolerances, compare_signals, log_signals

SIGNALS = ["plant.x", "plant.y", "plant.z", "plant.psi", "controller.f_R", "controller.f_L", "controller.tau_R",
           "controller.tau_L"]
STAGES = ("sil", "mil", "pil")
CASES_SCHEMA = {
    "type": "object", "additionalProperties": False, "required": ["cases"],
    "properties": {"cases": {"type": "array", "minItems": 1, "items": {
        "type": "object", "additionalProperties": False, "required": ["scenario", "trajectory"],
        "properties": {"scenario": {"enum": ["fsi", "lkf", "zse"]}, "trajectory": {"enum": [0, 1, 2, 3]},
                       "controller": {"enum": ["dlqr", "mixed"]}, "seed": {"type": "integer", "minimum": 0, "maximum": 2**31 - 1},
                       "stop_time": {"type": "number", "exclusiveMinimum": 0, "maximum": MAX_RUN}}}}},  # run's bound
}


@dataclass(frozen=True)
class Case:
    scenario: str
    trajectory: int
    controller: str = "dlqr"
    seed: int = SEED
    stop_time: float | None = None  # None: the trajectory's duration

    @property
    def name(self) -> str:
        return self.named(self.controller)

    def named(self, controller: str) -> str:
        """The case's name with another word for its controller (row_name's: what the sides ran)."""
        return f"{self.scenario}_traj{self.trajectory}_{controller}" + (f"_seed{self.seed}" if self.seed != SEED else "")


def row_name(case: Case, reference: Side, candidate: Side) -> str:
    """A case's row (and its logs) named by what the sides ran, not by the case file's controller where a side
    replaces it: fsi_traj1_mine_vs_theirs; one name when both ran the same controller (the sides differ otherwise)."""
    ran = [Path(c).stem if c.endswith(".fmu") else c for c in (side.controller or case.controller
                                                               for side in (reference, candidate))]
    return case.named(ran[0] if ran[0] == ran[1] else f"{ran[0]}_vs_{ran[1]}")


@dataclass(frozen=True)
class Side:
    """One of the two: its FMU folder, its controller (None: the case's; dlqr, mixed, a controller .fmu or a class's .py
    file, wrapped as run wraps it), its --set,
    the controller's stage (sil, mil, pil) and, for mil, gain (i, j, factor): the entry K[i, j] of the gain scaled (a
    deliberately broken candidate)."""

    fmus: Path = FMU_DIR
    controller: str | None = None
    settings: tuple[tuple[str, object], ...] = ()
    stage: str = "sil"
    gain: tuple[int, int, float] | None = None

    @property
    def label(self) -> str:
        gain = f", K[{self.gain[0]},{self.gain[1]}] x {self.gain[2]:g}" if self.gain else ""
        return f"{self.stage.upper()}{gain}"


def check_side(side: Side, role: str) -> None:
    """A side that cannot run, refused before anything runs: one line."""
    if not isinstance(side.fmus, (str, Path)) or not str(side.fmus):
        raise DescriptionError(f"the {role}'s fmus must be a folder (str or pathlib.Path), got {_shown(side.fmus)}")
    if side.controller is not None and not isinstance(side.controller, str):
        raise DescriptionError(f"the {role}'s controller must be dlqr, mixed or a controller FMU, got {_shown(side.controller)}")
    if not isinstance(side.settings, tuple) or not all(isinstance(p, tuple) and len(p) == 2 and isinstance(p[0], str)
                                                        for p in side.settings):
        raise DescriptionError(f"the {role}'s settings must be pairs ('instance.name', value), got {_shown(side.settings)}")
    if not isinstance(side.stage, str):
        raise DescriptionError(f"the {role}'s stage must be one of {', '.join(STAGES)}, got {_shown(side.stage)}")
    if side.stage not in STAGES:
        raise DescriptionError(f"the {role}'s stage {side.stage!r} is none of {', '.join(STAGES)}")
    if side.controller and side.controller.endswith(".fmu") and not Path(side.controller).is_file():
        raise DescriptionError(f"controller {side.controller} does not exist")
    if side.stage == "mil" and side.controller and side.controller.endswith(".fmu"):
        raise DescriptionError(f"the {role} runs as mil, the thesis's controller in Python: a controller FMU has no Python "
                               "form here (its pythonfmu or native wrap is the same class run as sil)")
    if side.gain is not None and side.stage != "mil":
        raise DescriptionError(f"the {role}'s gain change applies to the mil stage (the numpy reference) only")
    gain = side.gain
    if gain is not None and not (isinstance(gain, tuple) and len(gain) == 3 and all(_whole(i) and 0 <= i < 64 for i in gain[:2])
                                 and _finite(gain[2])):
        raise DescriptionError(f"the {role}'s gain must be (i, j, factor): two entries of K from 0 and a finite number, "
                               f"got {_shown(gain)}")


def _whole(x) -> bool:
    return isinstance(x, (int, np.integer)) and not isinstance(x, bool)


def _finite(x) -> bool:
    return isinstance(x, (int, float, np.integer, np.floating)) and not isinstance(x, bool) and bool(np.isfinite(x))


def _shown(value) -> str:
    """A value in an error line: short, its control characters escaped (one line)."""
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


def check_side_system(case: Case, side: Side, role: str) -> None:
    """What `run` checks before its first step, for this side's system: each --set a parameter the FMU has, of its type
    and range; a user's controller FMU with the ports the loop needs. One line naming the side."""
    from ...engine.fmi.model_description import checked_value, read_fmu
    from ..loop.parameter_types import check_settings
    from ..loop.ports import check_controller

    try:
        system = side_system(case, side)
        check_settings(system, side.settings)
        for key, value in side.settings:
            instance, _, name = key.partition(".")
            variables = {v.name: v for v in read_fmu(system.instance(instance).fmu, instance).modelVariables}
            checked_value(instance, variables.get(name), name, value)
        controller = side.controller or case.controller
        if controller.endswith(".fmu"):
            check_controller(read_fmu(Path(controller), "controller"))
    except (DescriptionError, UserFileError, UserError) as err:
        raise DescriptionError(f"the {role}: {err}") from None


@contextlib.contextmanager
def hosted(side: Side, controller_fmu: Path):
    """Where a side's controller runs while the block runs: None (in this process), or the server (pil.Served) of its
    mil or pil stage."""
    if side.stage == "mil":
        from .mil import served as serving
    elif side.stage == "pil":
        from .pil import served as serving
    else:
        yield None
        return
    with serving(controller_fmu, side.gain) if side.stage == "mil" else serving(controller_fmu, "aarch64-linux") as host:
        yield host


class ControllerTime(Observer):
    """The wall time the controller's calls took per tick in a run (a remote controller: the round trip, its own
    computation included; in this process the loop does not time its calls, so 0)."""

    def __init__(self) -> None:
        self.per_tick: float | None = None

    def start(self, execution) -> None:
        self._started = (execution.instances["controller"].fmi_seconds, execution.ticks_done)

    def on_batch(self, execution, batch) -> None:
        """Nothing a step: the time is read at the end."""

    def finish(self, execution, error) -> None:
        seconds, ticks = execution.instances["controller"].fmi_seconds, execution.ticks_done
        if ticks > self._started[1]:
            self.per_tick = (seconds - self._started[0]) / (ticks - self._started[1])


def reproduction_cases() -> list[Case]:
    from .reproduce import CASES

    return [Case(s, t, c) for s, t, c in CASES]


def load_cases(path: Path) -> list[Case]:
    """A case list: {"cases": [{"scenario": "lkf", "trajectory": 1, "controller": "dlqr", "seed": 1, "stop_time": 5}]}."""
    try:
        data = read_document(Path(path))
    except UserFileError as err:
        raise DescriptionError(str(err)) from None
    return checked_cases(data, str(path))


def checked_cases(data: object, where: str) -> list[Case]:
    """A case list ({"cases": [...]}, from a file or the API) through CASES_SCHEMA: every number finite, the stop time
    run's bound, scenarios and controllers by name; one line naming the place."""
    try:
        check_values(data, where)
    except UserFileError as err:
        raise DescriptionError(f"{where} is not a case list: {str(err).removeprefix(where + ': ')}") from None
    problem = schema_problem(data, CASES_SCHEMA, limit=120)
    if problem:
        raise DescriptionError(f"{where} is not a case list: {problem}")
    return [Case(**c) for c in data["cases"]]


def side_system(case: Case, side: Side, host=None):
    """The system of the case on this side; host (mil.Served or pil's): where its controller runs."""
    from ..loop.thesis import default_system, set_parameters

    controller = side.controller or case.controller
    is_fmu = controller.endswith(".fmu")
    system = default_system(side.fmus, case.scenario, case.trajectory, None if is_fmu else controller, case.seed,
                            controller_fmu=Path(controller) if is_fmu else None)
    set_parameters(system, dict(side.settings))
    if host is not None:
        instance = system.instance("controller")
        instance.remote, instance.token_file = host.address, host.token_file
    return system


def run_side(case: Case, side: Side, log: Path, stop: float | None, pool=None, host=None, role: str = "side"
             ) -> tuple[Path, str | None, float | None]:
    """One run of the case on this side (on the pool's execution of its structure, if any): (its log, how it ended
    early or None, the controller's time per tick in s, None when it runs in this process)."""
    from ...engine.lifecycle import RunPlan, run_plan
    from ..case.record import record
    from ..loop.fmus import is_foreign
    from ..loop.thesis import default_stop, loop_metrics

    controller = side.controller or case.controller
    stop = stop if stop is not None else case.stop_time if case.stop_time is not None else default_stop(case.trajectory)
    system = side_system(case, side, host)
    meta = record(scenario=case.scenario, trajectory=case.trajectory, controller=controller, seed=case.seed, stop_time=stop,
                  settings=side.settings)
    timer = ControllerTime()
    result = run_plan(RunPlan(system, stop, log, meta, metrics=loop_metrics(), observers=(timer,), isolate=is_foreign), pool)
    if result.error is not None and (not result.ticks or not log.is_file()):  # nothing to compare: the side's own line
        raise DescriptionError(f"{case.name}: the {role} did not start: {result.error}")
    return log, result.error, (timer.per_tick if host is not None else None)


def largest_deviation(mine: tuple[np.ndarray, np.ndarray], ref: tuple[np.ndarray, np.ndarray]) -> float:
    """The largest |candidate - reference| at the times both logged (inf where one is NaN or infinite and the other
    not); NaN when they share no time."""
    t, y = mine
    t_ref, y_ref = ref
    _, i, j = np.intersect1d(t, t_ref, assume_unique=False, return_indices=True)
    if not len(i):
        return float("nan")
    a, b = y[i], y_ref[j]
    same = (a == b) | (np.isnan(a) & np.isnan(b))
    with np.errstate(invalid="ignore"):
        diff = np.where(same, 0.0, np.abs(a - b))
    return float(np.nan_to_num(diff, nan=np.inf).max())


@dataclass(frozen=True)
class CaseResult:
    case: Case
    rows: list[SignalRow] = field(default_factory=list)
    error: str | None = None  # a side that could not run to its end (the candidate's part is still compared)
    deviation: dict[str, float] = field(default_factory=dict)  # per signal: the largest |candidate - reference|
    per_tick: tuple[float | None, float | None] = (None, None)  # the controller's time per tick (s), reference and
    # candidate: the round trip of a remote (mil, pil) controller; None in this process
    name: str = ""  # the row's: row_name (the case's own name where both sides ran its controller)

    @property
    def ok(self) -> bool:
        return self.error is None and all(r.passed for r in self.rows)

    def worst(self) -> SignalRow | None:
        """The signal outside its tube first (ties: the larger share outside)."""
        bad = [r for r in self.rows if not r.passed]
        return min(bad, key=lambda r: (r.first_outside, -r.share_outside)) if bad else None


@dataclass(frozen=True)
class BackToBack:
    results: list[CaseResult]
    changes: list[str]  # what differs between the reference's FMUs and the candidate's (the first case's logs)
    reference: Side | None = None
    candidate: Side | None = None
    tolerances: Tolerances = field(default_factory=Tolerances)

    @property
    def ok(self) -> bool:
        return all(r.ok for r in self.results)

    def table(self) -> str:
        width = max([4] + [len(r.name) for r in self.results])
        timed = [k for k in (0, 1) if any(r.per_tick[k] is not None for r in self.results)]
        head = "".join(f" {('ref' if k == 0 else 'cand') + ' us/tick':>13}" for k in timed)
        lines = [f"{'case':<{width}}  {'signals in':>10}  {'first out':<16} {'at (s)':>9} {'largest excess':>14} {'out %':>6}{head}"]
        for r in self.results:
            inside = f"{sum(x.passed for x in r.rows)}/{len(r.rows)}"
            worst = r.worst()
            times = "".join(f" {'-' if r.per_tick[k] is None else f'{1e6 * r.per_tick[k]:.0f}':>13}" for k in timed)
            if worst is None:
                lines.append(f"{r.name:<{width}}  {inside:>10}  {'-':<16} {'-':>9} {'-':>14} {'0':>6}{times}")
            else:
                lines.append(f"{r.name:<{width}}  {inside:>10}  {worst.signal:<16} {worst.first_outside:>9.6g} "
                             f"{worst.largest_excess:>14.4g} {100 * worst.share_outside:>6.3g}{times}")
            if r.error:
                lines.append(f"{'':<{width}}  ended early: {r.error}")
        return "\n".join(lines)


def back_to_back(cases: list[Case], reference: Side, candidate: Side, out: Path, signals: list[str] | None = None,
                 tolerances: Tolerances | None = None, stop: float | None = None, echo=print, pool=None) -> BackToBack:
    """Each case run on both sides into out/, then the candidate's signals in the reference's tubes. pool: the
    ExecutionPool the runs go through (None: one for this call, closed at its end)."""
    from ...engine.lifecycle import ExecutionPool
    from ...engine.log.reader import read_metadata
    from .changes import what_changed

    names = signals or SIGNALS
    tolerances = tolerances or Tolerances()
    check_side(reference, "reference")  # refused before anything runs
    check_side(candidate, "candidate")
    unknown = [n for n in tolerances.signals if n not in names]
    if unknown:  # a tolerance for a signal not compared: a typo would go unnoticed
        raise DescriptionError(f"the tolerances name {', '.join(unknown)}, which are not among the compared signals ({', '.join(names)})")
    from ..output_folder import writable_folder

    out = writable_folder(Path(out), "--out", min_free=0)
    for side, role in ((reference, "reference"), (candidate, "candidate")):
        check_side_system(cases[0], side, role)  # run's checks, before anything runs
    out.mkdir(parents=True, exist_ok=True)
    results, changes = [], None
    with contextlib.ExitStack() as stack:
        hosts = [stack.enter_context(hosted(side, side_system(cases[0], side).instance("controller").fmu))
                 for side in (reference, candidate)]
        if pool is None:
            pool = stack.enter_context(contextlib.closing(ExecutionPool()))
        for k, case in enumerate(cases, start=1):
            name = row_name(case, reference, candidate)
            ref_log, ref_error, ref_time = run_side(case, reference, out / f"{name}_reference.mcap", stop, pool, hosts[0],
                                                  "reference")
            if ref_error is not None:
                raise DescriptionError(f"{name}: the reference run failed ({ref_error}): nothing to compare with")
            ref, units = log_signals(ref_log, names)  # a signal the log does not have: refused before the candidate runs
            cand_log, cand_error, cand_time = run_side(case, candidate, out / f"{name}_candidate.mcap", stop, pool, hosts[1],
                                                     "candidate")
            if changes is None:
                changes = what_changed(read_metadata(ref_log).get("fmus"), read_metadata(cand_log).get("fmus"))
            mine, _ = log_signals(cand_log, names)
            result = CaseResult(case, compare_signals(mine, ref, tolerances, units), cand_error,
                                {n: largest_deviation(mine[n], ref[n]) for n in names}, (ref_time, cand_time), name)
            results.append(result)
            echo(f"  [{k}/{len(cases)}] {name}: {'same' if result.ok else 'DIFFERENT'}")
    staged = [f"controller run as {reference.label} -> {candidate.label}"] if reference.label != candidate.label else []
    return BackToBack(results, staged + (changes or []), reference, candidate, tolerances)

"""`tiltload b2b`: a case list run twice, with a reference and a candidate (two controllers, two builds of the FMUs, a
parameter changed), compared signal by signal in tolerance tubes (docs/back_to_back.md): a table, a case a row.

A side is what differs between the two: the FMU folder, the controller (dlqr, mixed or a controller FMU; by default
the case's) and --set values. Both sides of a case run the same scenario, trajectory, seed and stop time.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from ...engine.argument_types import MAX_RUN
from ...engine.errors import DescriptionError
from ...engine.user_files import UserFileError, read_document, schema_problem
from .signal_compare import SignalRow, Tolerances, compare_signals, log_signals

SIGNALS = ["plant.x", "plant.y", "plant.z", "plant.psi", "controller.f_R", "controller.f_L", "controller.tau_R",
           "controller.tau_L"]
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
    seed: int = 1
    stop_time: float | None = None  # None: the trajectory's duration

    @property
    def name(self) -> str:
        return f"{self.scenario}_traj{self.trajectory}_{self.controller}" + (f"_seed{self.seed}" if self.seed != 1 else "")


@dataclass(frozen=True)
class Side:
    """One of the two: its FMU folder, its controller (None: the case's; dlqr, mixed, or a controller .fmu), its --set."""

    fmus: Path
    controller: str | None = None
    settings: tuple[tuple[str, object], ...] = ()


def reproduction_cases() -> list[Case]:
    from .reproduce import CASES

    return [Case(s, t, c) for s, t, c in CASES]


def load_cases(path: Path) -> list[Case]:
    """A case list: {"cases": [{"scenario": "lkf", "trajectory": 1, "controller": "dlqr", "seed": 1, "stop_time": 5}]}."""
    try:
        data = read_document(Path(path))
    except UserFileError as err:
        raise DescriptionError(str(err)) from None
    problem = schema_problem(data, CASES_SCHEMA)
    if problem:
        raise DescriptionError(f"{path} is not a case list: {problem}")
    return [Case(**c) for c in data["cases"]]


def run_side(case: Case, side: Side, log: Path, stop: float | None) -> tuple[Path, str | None]:
    """One run of the case on this side: (its log, how it ended early or None)."""
    from ...engine.run import run_system
    from ..fmus import is_foreign
    from ..loop import default_stop, default_system, loop_metrics, set_parameters
    from .case import record

    controller = side.controller or case.controller
    is_fmu = controller.endswith(".fmu")
    if is_fmu and not Path(controller).is_file():
        raise DescriptionError(f"controller {controller} does not exist")
    stop = stop if stop is not None else case.stop_time if case.stop_time is not None else default_stop(case.trajectory)
    system = default_system(side.fmus, case.scenario, case.trajectory, None if is_fmu else controller, case.seed,
                            controller_fmu=Path(controller) if is_fmu else None)
    set_parameters(system, dict(side.settings))
    meta = record(scenario=case.scenario, trajectory=case.trajectory, controller=controller, seed=case.seed, stop_time=stop,
                  settings=side.settings)
    result = run_system(system, stop, log, loop_metrics(), progress=False, metadata=meta, isolate=is_foreign)
    return log, result.error


@dataclass(frozen=True)
class CaseResult:
    case: Case
    rows: list[SignalRow] = field(default_factory=list)
    error: str | None = None  # a side that could not run to its end (the candidate's part is still compared)

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

    @property
    def ok(self) -> bool:
        return all(r.ok for r in self.results)

    def table(self) -> str:
        width = max([4] + [len(r.case.name) for r in self.results])
        lines = [f"{'case':<{width}}  {'signals in':>10}  {'first out':<16} {'at (s)':>9} {'largest excess':>14} {'out %':>6}"]
        for r in self.results:
            inside = f"{sum(x.passed for x in r.rows)}/{len(r.rows)}"
            worst = r.worst()
            if worst is None:
                lines.append(f"{r.case.name:<{width}}  {inside:>10}  {'-':<16} {'-':>9} {'-':>14} {'0':>6}")
            else:
                lines.append(f"{r.case.name:<{width}}  {inside:>10}  {worst.signal:<16} {worst.first_outside:>9.6g} "
                             f"{worst.largest_excess:>14.4g} {100 * worst.share_outside:>6.3g}")
            if r.error:
                lines.append(f"{'':<{width}}  ended early: {r.error}")
        return "\n".join(lines)


def back_to_back(cases: list[Case], reference: Side, candidate: Side, out: Path, signals: list[str] | None = None,
                 tolerances: Tolerances | None = None, stop: float | None = None, echo=print) -> BackToBack:
    """Each case run on both sides into out/, then the candidate's signals in the reference's tubes."""
    from ...engine.log_reader import read_metadata
    from .changes import what_changed

    names = signals or SIGNALS
    tolerances = tolerances or Tolerances()
    for side in (reference, candidate):  # refused before anything runs
        if side.controller and side.controller.endswith(".fmu") and not Path(side.controller).is_file():
            raise DescriptionError(f"controller {side.controller} does not exist")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    results, changes = [], None
    for k, case in enumerate(cases, start=1):
        ref_log, ref_error = run_side(case, reference, out / f"{case.name}_reference.mcap", stop)
        if ref_error is not None:
            raise DescriptionError(f"{case.name}: the reference run failed ({ref_error}): nothing to compare with")
        cand_log, cand_error = run_side(case, candidate, out / f"{case.name}_candidate.mcap", stop)
        if changes is None:
            changes = what_changed(read_metadata(ref_log).get("fmus"), read_metadata(cand_log).get("fmus"))
        ref, units = log_signals(ref_log, names)
        mine, _ = log_signals(cand_log, names)
        result = CaseResult(case, compare_signals(mine, ref, tolerances, units), cand_error)
        results.append(result)
        echo(f"  [{k}/{len(cases)}] {case.name}: {'same' if result.ok else 'DIFFERENT'}")
    return BackToBack(results, changes or [])

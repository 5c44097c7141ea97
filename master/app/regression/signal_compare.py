"""Signals of a run against a baseline's (a signal baseline file or another log), each inside its tolerance tube
(engine/tubes.py, docs/back_to_back.md): the case first (as `compare` checks it), what changed in the FMUs, then each
signal's verdict, first time outside, largest excess and share of time outside.

Tolerances per signal: "abs", "rel", "lead", "lag" (s) from a tolerance file (TOML, YAML or JSON: a "default" table and
a "signals" table keyed by "instance.variable"; the file's default for a signal it does not name), else the baseline's
own, else DEFAULT; a flag replaces that one tolerance for every signal.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ...engine.errors import DescriptionError
from ...engine.tubes import Tolerance, Tube, tube

DEFAULT = Tolerance(absolute=1e-12, relative=1e-6)
KEYS = {"abs": "absolute", "rel": "relative", "lead": "lead", "lag": "lag"}
Signals = dict[str, tuple[np.ndarray, np.ndarray]]


def tolerance_from(data: object, where: str, base: Tolerance = DEFAULT) -> Tolerance:
    """A {abs, rel, lead, lag} mapping over base: every key known, every value a finite number >= 0."""
    if not isinstance(data, dict):
        raise DescriptionError(f"{where}: must be a table of abs, rel, lead, lag")
    values = {}
    for key, value in data.items():
        if key not in KEYS:
            raise DescriptionError(f"{where}: unknown tolerance {key!r} (abs, rel, lead, lag)")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0:
            raise DescriptionError(f"{where}: {key} = {value!r} must be a finite number >= 0")
        values[KEYS[key]] = float(value)
    return replace(base, **values)


def as_mapping(tol: Tolerance) -> dict[str, float]:
    return {short: getattr(tol, full) for short, full in KEYS.items()}


@dataclass(frozen=True)
class Tolerances:
    """The default and each named signal's tolerance."""

    default: Tolerance = DEFAULT
    signals: dict[str, Tolerance] = field(default_factory=dict)

    def of(self, name: str) -> Tolerance:
        return self.signals.get(name, self.default)

    def with_flags(self, flags: dict[str, float | None]) -> Tolerances:
        """Each given flag (abs, rel, lead, lag) in place of that tolerance, for every signal."""
        given = {KEYS[k]: float(v) for k, v in flags.items() if v is not None}
        if not given:
            return self
        return Tolerances(replace(self.default, **given), {n: replace(t, **given) for n, t in self.signals.items()})

    def to_header(self) -> dict:
        return {"default": as_mapping(self.default), "signals": {n: as_mapping(t) for n, t in self.signals.items()}}


def parse_tolerances(data: object, where: str) -> Tolerances:
    """A tolerance document: {"default": {...}, "signals": {"plant.x": {...}, ...}}."""
    if not isinstance(data, dict) or set(data) - {"default", "signals"}:
        extra = sorted(set(data) - {"default", "signals"}) if isinstance(data, dict) else []
        raise DescriptionError(f"{where}: a tolerance file has a 'default' and a 'signals' table"
                               + (f", not {', '.join(map(repr, extra))}" if extra else ""))
    default = tolerance_from(data.get("default", {}), f"{where}: default")
    signals = data.get("signals", {})
    if not isinstance(signals, dict):
        raise DescriptionError(f"{where}: signals must be a table keyed by instance.variable")
    out = {}
    for name, entry in signals.items():
        if not _is_signal_name(name):
            raise DescriptionError(f"{where}: signal {name!r} is not named instance.variable (plant.x, controller.f_R)")
        out[name] = tolerance_from(entry, f"{where}: signals.{name}", default)
    return Tolerances(default, out)


def load_tolerances(path: Path) -> Tolerances:
    from ...engine.user_files import UserFileError, read_document

    try:
        data = read_document(Path(path))
    except UserFileError as err:
        raise DescriptionError(str(err)) from None
    return parse_tolerances(data, str(path))


def log_signals(log: Path, names: list[str]) -> tuple[Signals, dict[str, str]]:
    """({name: (times, values)}, units) of "instance.variable" signals of a log; a name it lacks: one line naming it."""
    from ...engine.log.reader import DamagedLog, read_columns, read_metadata

    topics = sorted({f"/{n.split('.')[0]}" for n in names})
    columns, state = read_columns(Path(log), topics)
    if state.damage is not None:
        raise DamagedLog(state.describe(Path(log)))
    out = {}
    for name in names:
        instance, variable = name.split(".", 1)
        channel = columns.get(f"/{instance}")
        if channel is None:
            raise DescriptionError(f"{log} logs no instance {instance!r}: {name} names no logged signal")
        times, values = channel
        if variable not in values:
            raise DescriptionError(f"{log} has no signal {name} ({instance} logs {', '.join(list(values)[:12])}"
                                   + (", ..." if len(values) > 12 else "") + ")")
        out[name] = (times, values[variable])
    return out, read_metadata(Path(log)).get("units", {})


def _is_signal_name(name: str) -> bool:
    """instance.variable: an instance (no dot) and a variable (which may hold dots, FMI's structured names)."""
    instance, dot, variable = name.partition(".")
    return bool(instance and dot and variable)


def check_names(names: list[str], where: str) -> list[str]:
    for name in names:
        if not _is_signal_name(name):
            raise DescriptionError(f"{where}: signal {name!r} is not named instance.variable (plant.x, controller.f_R)")
    return list(dict.fromkeys(names))


@dataclass(frozen=True, eq=False)
class SignalRow:
    """One signal's verdict: inside its tube everywhere, or where it left it first, by how much at most, for how long."""

    signal: str
    tolerance: Tolerance
    passed: bool
    first_outside: float | None  # s
    largest_excess: float | None  # in the signal's unit; inf for a NaN, infinite or missing candidate
    excess_at: float | None  # s
    share_outside: float  # of the compared time
    unit: str = ""
    tube: Tube | None = field(default=None, repr=False)
    reference: tuple[np.ndarray, np.ndarray] | None = field(default=None, repr=False)

    @property
    def status(self) -> str:
        return "ok" if self.passed else "OUTSIDE"

    def words(self) -> str:
        """"first outside at t = 0.312 s; largest excess 0.0021 m at t = 0.9 s; outside 41 % of the time"."""
        if self.passed:
            return "inside its tube"
        unit = f" {self.unit}" if self.unit and self.unit != "1" else ""
        excess = ("a NaN, infinite or missing value" if self.largest_excess == math.inf
                  else f"{self.largest_excess:.4g}{unit}")
        return (f"first outside at t = {self.first_outside:.6g} s; largest excess {excess} at t = {self.excess_at:.6g} s; "
                f"outside {100 * self.share_outside:.3g} % of the time")


def compare_signals(run: Signals, base: Signals, tolerances: Tolerances, units: dict[str, str] | None = None) -> list[SignalRow]:
    """Each of the baseline's signals (in its order) of the run inside the baseline's tube."""
    rows = []
    for name, (t_ref, y_ref) in base.items():
        t, y = run[name]
        tol = tolerances.of(name)
        try:
            result = tube(t_ref, y_ref, t, y, tol, what=name)
        except ValueError as err:
            raise DescriptionError(str(err)) from None
        largest = result.largest_excess
        rows.append(SignalRow(name, tol, result.passed, result.first_outside, largest and largest[0], largest and largest[1],
                              result.share_outside, (units or {}).get(name, ""), result, (t_ref, y_ref)))
    return rows


@dataclass(frozen=True)
class SignalComparison:
    """A run's signals against a baseline's, after their cases were checked to be the same (or any_case was asked)."""

    ok: bool
    rows: list[SignalRow]
    case_differences: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    changes: list[str] = field(default_factory=list)  # what changed in the FMUs and their parameters, told first
    case: dict = field(default_factory=dict)  # the run's case record

    def table(self) -> str:
        width = max([6] + [len(r.signal) for r in self.rows])
        lines = [f"{'signal':>{width}}  status   {'first out (s)':>13} {'largest excess':>14} {'at (s)':>9} {'out %':>6}  tolerance"]
        for r in self.rows:
            first, at = ("-", "-") if r.passed else (f"{r.first_outside:.6g}", f"{r.excess_at:.6g}")
            excess = "-" if r.passed else f"{r.largest_excess:.4g}"
            lines.append(f"{r.signal:>{width}}  {r.status:<7}  {first:>13} {excess:>14} {at:>9} {100 * r.share_outside:>6.3g}  "
                         f"{r.tolerance.words()}")
        return "\n".join(lines)

    def changed_line(self) -> str | None:
        from .changes import summary

        return summary(self.changes) if self.changes else None

    def report(self, baseline: Path | str, command: str = "", what: str = "the run", update_hint: str | None = None) -> str:
        """The message of a run whose signals leave their tubes: what changed first, then each signal outside."""
        from ..case.record import describe

        bad = [r for r in self.rows if not r.passed]
        counted = f"{len(bad)} of {len(self.rows)} signals outside their tolerance tubes"
        lines = ([f"{what} differs from its signal baseline; {self.changed_line()}", f"  {counted}"] if self.changes
                 else [f"{what} differs from its signal baseline: {counted}"])
        lines += [f"  case:     {describe(self.case)}" if self.case else "  case:     not recorded", f"  baseline: {baseline}"]
        width = max([0] + [len(r.signal) for r in bad])
        for r in bad:
            lines.append(f"    {r.signal:<{width}}  {r.words()} ({r.tolerance.words()})")
        good = [r.signal for r in self.rows if r.passed]
        if good:
            lines.append(f"  within their tubes: {', '.join(good)}")
        lines += [f"  note: {n}" for n in self.notes]
        if command:
            lines.append(f"  rerun:    {command}")
        if update_hint:
            lines.append(f"  if the change is intended, record the new baseline: {update_hint}")
        return "\n".join(lines)


def load_reference(path: Path, names: list[str] | None, named_by: Path | str | None = None
                   ) -> tuple[Signals, Tolerances, dict, dict | None, dict | None]:
    """(signals, tolerances, units, case, fmus) of a signal baseline (.parquet) or a log (.mcap); named_by: where the
    names come from, when not from --signals (a name the baseline lacks is that file's error)."""
    from . import signal_baseline

    path = Path(path)
    if path.suffix == ".parquet":
        header, signals = signal_baseline.read(path)
        recorded = header.get("tolerances", {})
        tolerances = parse_tolerances(recorded, f"{path} (its tolerances)") if recorded else Tolerances()
        if names:
            missing = [n for n in names if n not in signals]
            if missing:
                raise DescriptionError((f"{named_by}: {missing[0]} names no signal of {path}" if named_by else
                                        f"{path} holds no signal {missing[0]}") + f" (it holds {', '.join(signals)})")
            signals = {n: signals[n] for n in names}
        return signals, tolerances, header.get("units", {}), header.get("run") or None, header.get("fmus") or None
    _check_log(path)
    if not names:
        raise DescriptionError(f"{path} is a log: name the signals to compare (--signals plant.x,plant.z, or a tolerance "
                               "file's signals)")
    from ...engine.log.reader import read_metadata

    try:
        signals, units = log_signals(path, names)
    except DescriptionError as err:
        raise DescriptionError(f"{named_by}: {err}" if named_by else str(err)) from None
    meta = read_metadata(path)
    return signals, Tolerances(), units, meta.get("run") or None, meta.get("fmus") or None


def _check_log(path: Path, role: str = "baseline") -> None:
    if not path.is_file():
        raise DescriptionError(f"{path} does not exist")
    with open(path, "rb") as f:
        if f.read(8) != b"\x89MCAP0\r\n":
            raise DescriptionError(f"{path} is not an MCAP log (the {role} must be "
                                   + ("one)" if role == "run" else "one or a signal baseline, .parquet)"))


def compare_signal_files(run: Path, baseline: Path, signals: list[str] | None = None, tolerance_file: Path | None = None,
                         flags: dict[str, float | None] | None = None, any_case: bool = False,
                         given: Tolerances | None = None) -> SignalComparison:
    """`tiltload compare RUN BASELINE --signals ...`: the case, what changed, then each signal in its tube. Tolerances:
    a tolerance file's, or given ones, in place of the baseline's own; flags replace one of them for every signal."""
    from ...engine.log.reader import read_metadata
    from .changes import between
    from .compare import compare_cases

    for flag, value in (flags or {}).items():
        if value is not None:
            tolerance_from({flag: value}, "tolerance for every signal")  # one line for a bad one, not Tolerance's ValueError
    if tolerance_file is not None:
        given = load_tolerances(tolerance_file)
    names = check_names(signals, "--signals") if signals else None
    from_tolerances = names is None and given is not None and bool(given.signals)
    base, recorded, units, base_case, base_fmus = load_reference(baseline, list(given.signals) if from_tolerances else names,
                                                                 tolerance_file or "the tolerances" if from_tolerances else None)
    names = list(base)
    if given is not None:
        _check_known(given, names, tolerance_file or "the tolerances")
    tolerances = (given if given is not None else recorded).with_flags(flags or {})  # a file replaces the recorded ones
    _check_log(Path(run), "run")
    notes: list[str] = []
    meta = read_metadata(Path(run))
    run_case = meta.get("run") or None
    what = compare_cases(run_case, base_case, str(run), str(baseline), any_case, notes)
    changes = between(base_fmus, meta.get("fmus") or None, base_case, run_case)
    mine, run_units = log_signals(Path(run), names)
    rows = compare_signals(mine, base, tolerances, {**run_units, **units})
    notes += uncompared_tail(mine, base)
    return SignalComparison(all(r.passed for r in rows), rows, what, notes, changes, dict(run_case or {}))


def uncompared_tail(run: Signals, base: Signals) -> list[str]:
    """A note when the run goes on past the baseline's end (another case's baseline, --any-case): the tubes are judged
    over the baseline's span, so that part of the run is not compared, and a reader must not take it as compared."""
    ends = [(run[n][0][-1], t_ref[-1]) for n, (t_ref, _) in base.items() if len(t_ref) and len(run[n][0])]
    run_end, base_end = max(e[0] for e in ends) if ends else 0.0, max(e[1] for e in ends) if ends else 0.0
    if run_end > base_end:
        return [f"the run goes on to t = {run_end:.6g} s, past the baseline's end at t = {base_end:.6g} s: not compared there "
                "(tubes are judged over the baseline's span)"]
    return []


def _check_known(tolerances: Tolerances, names: list[str], source: Path | str) -> None:
    """A tolerance for a signal that is not compared names no logged signal: refused, as a typo would go unnoticed."""
    unknown = [n for n in tolerances.signals if n not in names]
    if unknown:
        raise DescriptionError(f"{source}: {unknown[0]} names no compared signal (the signals compared: {', '.join(names)})")


def record(log: Path, path: Path, signals: list[str], tolerances: Tolerances = Tolerances(),
           inputs: dict[str, Path | None] | None = None) -> Path:
    """A signal baseline of these signals of a run's log, with its case, FMUs and these tolerances; path is none of
    the log and the other inputs named ({"the tolerance file": ...})."""
    from ...engine.log.reader import read_metadata
    from ..output_folder import writable_file
    from . import signal_baseline

    writable_file(Path(path), "the signal baseline", {"the log it records": Path(log), **(inputs or {})})  # before the log is read
    names = check_names(signals, "signals")
    if not names:
        raise DescriptionError("a signal baseline needs at least one signal (instance.variable)")
    _check_known(tolerances, names, "the tolerances")
    values, units = log_signals(Path(log), names)
    meta = read_metadata(Path(log))
    header = {"run": meta.get("run", {}), "fmus": meta.get("fmus", {}), "tolerances": tolerances.to_header(),
              "units": {n: units[n] for n in names if n in units}, "signals": names}
    return signal_baseline.write(path, values, header)

"""What tiltload.run returns: the metrics, the case, the log, its signals, the command that reproduces it."""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from .errors import TiltloadError

if TYPE_CHECKING:
    import numpy as np
    import pandas as pd

    from ...engine.requirement.check import Result as RequirementResult
    from ..case.record import FmuRecord
    from .case import Case
    from .run_options import RunOptions


@dataclass(frozen=True, eq=False)  # arrays: no elementwise == for the whole
class Signals(Mapping[str, "np.ndarray"]):
    """One channel of a run's log (/plant, /controller, /scenario, /sensors): its time and each value, numpy arrays of
    the same length. ``signals["x"]`` is a value's array; ``signals.to_dataframe()`` all of them, indexed by time."""

    topic: str
    time: np.ndarray
    values: dict[str, np.ndarray]

    def __getitem__(self, name: str) -> np.ndarray:
        try:
            return self.values[name]
        except KeyError:
            raise KeyError(f"{self.topic} has no {name!r}; it has {', '.join(self.values)}") from None

    def __iter__(self) -> Iterator[str]:
        return iter(self.values)

    def __len__(self) -> int:
        return len(self.values)

    def to_dataframe(self) -> pd.DataFrame:
        import pandas as pd

        return pd.DataFrame(self.values, index=pd.Index(self.time, name="t"))


def read_signals(log: Path, topic: str) -> Signals:
    """A channel of a log as arrays (a value missing from a message, e.g. a dropped sample, is NaN)."""
    import numpy as np

    from ...engine.log.reader import read

    messages = read(log, topics=[topic]).get(topic)
    if not messages:
        raise TiltloadError(f"{log} has no channel {topic} (the loop's are /plant, /controller, /scenario, /sensors)")
    names = [k for k, v in messages[0].items() if k != "t" and isinstance(v, (int, float))]
    values = {n: np.array([np.nan if m.get(n) is None else m[n] for m in messages], dtype=float) for n in names}
    return Signals(topic, np.array([m["t"] for m in messages], dtype=float), values)


@dataclass(frozen=True)
class Result:
    """A run of the loop (or of a system file) made by tiltload.run, or read back from its log by tiltload.open_log.

    metrics: ISE and IADU by name (floats), as the `tiltload run` table and the log's metrics record have them.
    case, options: the Case and RunOptions it ran. record: the log's "run" record (what `tiltload compare` checks
    before the metrics), values as text. log: the MCAP log (None with no_log=True). command: the `tiltload run`
    command line that makes the same run. requirements: each monitored requirement's result (name, verdict,
    robustness, first_violation, values). fmus: the FMUs the log records.
    """

    metrics: dict[str, float]
    case: Case | None
    options: RunOptions | None
    record: dict[str, str]
    log: Path | None
    command: str
    stop_time: float
    sim_time: float
    wall_time: float  # s
    ticks: int
    plots: tuple[Path, ...] = ()
    transcript: str = ""  # what the command would have printed on stdout
    requirements: tuple[RequirementResult, ...] = ()
    fmus: tuple[FmuRecord, ...] = ()  # each instance's FMU as the log records it (model, GUID, SHA-256)
    profile: object = None  # with RunOptions(profile=True): where the ticks' time went (engine.profile.RunProfile)
    _cache: dict[str, Signals] = field(default_factory=dict, repr=False, compare=False)

    @property
    def verdicts(self) -> dict[str, str]:
        """Each monitored requirement's verdict by name (run with requirements=FILE): PASS, FAIL, INCONCLUSIVE, ZERO."""
        return {r.name: r.verdict for r in self.requirements}

    def signals(self, topic: str = "/plant") -> Signals:
        """A channel of the log as numpy arrays (read once)."""
        if self.log is None:
            raise TiltloadError("the run has no log (no_log=True): no signals to read")
        if topic not in self._cache:
            self._cache[topic] = read_signals(self.log, topic)
        return self._cache[topic]

    def to_dataframe(self, topic: str = "/plant") -> pd.DataFrame:
        """A channel of the log as a pandas DataFrame indexed by time (s)."""
        return self.signals(topic).to_dataframe()

    def _repr_html_(self) -> str:
        """The run's report (`tiltload run --report`'s), inline in a notebook."""
        from .rich_display import html_fragment, run_report

        return html_fragment(run_report(self))


def open_log(log: Path | str) -> Result:
    """The log of any earlier run as the Result tiltload.run returned for it, from the record the log carries (the
    case, its FMUs, metrics, the requirements' formulas): the case rebuilt as a Case where every file it names still
    exists (else None: the record keeps it as text), the requirements judged again on the log with the formulas the
    run monitored (the same verdicts), the command that replays it. A file that is no tiltload log is a TiltloadError."""
    from ...engine.log.reader import DamagedLog, ForeignLog, read_metadata
    from ...engine.requirement.check import check_log
    from ...engine.requirement.files import requirement
    from ..case.record import fmus_of_metadata, metrics_of_metadata, replay_command
    from .errors import as_tiltload_errors

    log = Path(log)
    with as_tiltload_errors():
        try:
            meta = read_metadata(log)
        except (DamagedLog, ForeignLog, OSError) as err:
            raise TiltloadError(f"{log}: {err}") from None
        run = {k: str(v) for k, v in meta.get("run", {}).items()}
        if not run:
            raise TiltloadError(f"{log}: no run record: not a log of `tiltload run` (or tl.run)")
        formulas = meta.get("requirement_formulas", {})
        reqs = [requirement(name, text) for name, text in formulas.items()] if isinstance(formulas, dict) else []
        judged = tuple(check_log(log, reqs, missing="inconclusive")) if reqs else ()
    numbers, ticks = metrics_of_metadata(meta)
    fmus, _ = fmus_of_metadata(meta.get("fmus", {}) if isinstance(meta.get("fmus"), dict) else {})
    stop = float(run.get("stop_time") or "nan")
    return Result(metrics=numbers, case=case_of_record(run), options=None, record=run, log=log,
                  command=replay_command(run), stop_time=stop, sim_time=float(meta.get("metrics", {}).get("sim_time", stop)),
                  wall_time=float("nan"), ticks=ticks, requirements=judged, fmus=fmus)


def case_of_record(run: dict) -> Case | None:
    """The Case a log's "run" record describes, or None where it cannot be rebuilt (a file it names is gone, a
    trajectory file recorded by its label). Where the FMUs were built is no part of the record: the default folder."""
    from ..loop.thesis import parse_value
    from .case import Case

    fields = {}
    if run.get("system"):
        fields = {"system": run["system"], "faults": run.get("faults") or None,
                  "start_time": float(run["start_time"]) if run.get("start_time") else None}
    else:
        trajectory = run.get("trajectory", "")
        fields = {"vehicle": run.get("vehicle"), "scenario": run.get("scenario"),
                  "trajectory": int(trajectory) if trajectory.isdecimal() else trajectory, "controller": run.get("controller"),
                  "seed": int(run["seed"]) if run.get("seed", "").isdecimal() else None, "delay": run.get("delay") == "True",
                  "no_gusts": run.get("gusts") == "False", "fmi": int(run["fmi"]) if run.get("fmi", "").isdecimal() else None,
                  "clocks": run.get("clocks") == "True", "faults": run.get("faults") or None, "wind": run.get("wind") or None,
                  "schedule": run.get("schedule") or None,
                  "set": tuple((k, parse_value(v)) for k, _, v in (s.partition("=") for s in run.get("set", "").split()))}
    try:
        return Case(**{k: v for k, v in fields.items() if v is not None},
                    stop_time=float(run["stop_time"]) if run.get("stop_time") else None)
    except (TiltloadError, TypeError, ValueError):
        return None

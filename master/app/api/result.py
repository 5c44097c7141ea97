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
    """A run of the loop (or of a system file) made by tiltload.run.

    metrics: ISE and IADU by name (floats), as the `tiltload run` table and the log's metrics record have them.
    case, options: the Case and RunOptions it ran. record: the log's "run" record (what `tiltload compare` checks
    before the metrics), values as text. log: the MCAP log (None with no_log=True). command: the `tiltload run`
    command line that makes the same run. requirements: each monitored requirement's result (name, verdict,
    robustness, first_violation, values).
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

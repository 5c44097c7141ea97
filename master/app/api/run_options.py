"""RunOptions: how a case is run and what is kept of it (log, figures, requirements, snapshots, pacing, where FMUs
run), beside the Case itself; checked when built, as `tiltload run`'s parser checks the same options."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ..case.fields import RUN, snapshot_time
from . import field_types as kinds
from .field_types import closest_field


@closest_field
@dataclass(frozen=True, kw_only=True)
class RunOptions:
    """The options of `tiltload run` that are not the case: field names as the options' (``--no-plots`` is
    ``no_plots``). snapshot_at: (T, FILE). realtime: a factor (``True`` is 1). quiet: no progress bar."""

    out: Path = Path("runs")
    name: str | None = None  # the log's file stem (default: what sets the run apart)
    no_log: bool = False  # metrics only; implies no_plots
    no_plots: bool = False
    log_every: int = 1
    requirements: Path | None = None  # monitored while the run goes
    stop_on_violation: bool = False
    snapshot_at: tuple[float | str, Path] | None = None
    from_snapshot: Path | None = None
    realtime: float | None = None
    max_overruns: int | None = None
    trust_fmus: bool = False
    step_timeout: float | None = None  # s
    token_file: Path | None = None
    quiet: bool = False
    report: Path | None = None  # a self-contained HTML report of the run (docs/reports.md)
    expect_fmu: tuple[tuple[str, str], ...] = ()  # (instance, SHA-256): refused before the run when its FMU differs
    profile: bool = False  # where the ticks' time went (Result.profile; engine/profile.py)

    def __post_init__(self) -> None:
        fix = self._fix
        fix("out", kinds.path("RunOptions", "out", self.out, False))
        RUN.check("out", self.out)  # the core's field types (case/fields.py), as the command's parser
        if kinds.text("RunOptions", "name", self.name) is not None:
            RUN.check("name", self.name)
        for name in ("no_log", "no_plots", "stop_on_violation", "trust_fmus", "quiet", "profile"):
            kinds.flag("RunOptions", name, getattr(self, name))
        log_every = fix("log_every", kinds.whole("RunOptions", "log_every", self.log_every, False))
        RUN.check("log_every", log_every)
        for name in ("requirements", "from_snapshot", "token_file", "report"):
            fix(name, kinds.path("RunOptions", name, getattr(self, name)))
        if self.report is not None:
            RUN.check("report", self.report)
        self._snapshot_at()
        expected = kinds.pairs("RunOptions", "expect_fmu", self.expect_fmu, (str,), "a str SHA-256")
        fix("expect_fmu", tuple(RUN.check("expect_fmu", f"{k}={v}") for k, v in expected))
        if self.realtime is True:
            fix("realtime", 1.0)
        if fix("realtime", kinds.number("RunOptions", "realtime", self.realtime)) is not None:
            fix("realtime", RUN.check("realtime", self.realtime))
        if fix("max_overruns", kinds.whole("RunOptions", "max_overruns", self.max_overruns)) is not None:
            RUN.check("max_overruns", self.max_overruns)
        if fix("step_timeout", kinds.number("RunOptions", "step_timeout", self.step_timeout)) is not None:
            fix("step_timeout", RUN.check("step_timeout", self.step_timeout))

    def _fix(self, name: str, value: object) -> object:
        object.__setattr__(self, name, value)  # frozen: normalized once, while built
        return value

    def _snapshot_at(self) -> None:
        """(T, FILE): T a number of seconds (the command line's text is kept: the log's name has it as typed)."""
        if self.snapshot_at is None:
            return
        if not isinstance(self.snapshot_at, (tuple, list)) or len(self.snapshot_at) != 2:
            raise TypeError(f"RunOptions.snapshot_at must be (T, FILE), got {self.snapshot_at!r:.80}")
        at, where = self.snapshot_at
        if isinstance(at, bool) or not isinstance(at, (int, float, str)):
            raise TypeError(f"RunOptions.snapshot_at's T must be a number of seconds, got {type(at).__name__} {at!r:.80}")
        snapshot_time(at)
        self._fix("snapshot_at", (at, kinds.path("RunOptions", "snapshot_at's FILE", where, False)))

    @property
    def snapshot_time(self) -> float | None:
        """snapshot_at's T in seconds."""
        return None if self.snapshot_at is None else float(self.snapshot_at[0])

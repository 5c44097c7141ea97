"""tiltload.falsify: a falsification spec searched with its FalsifyOptions by the same core as `tiltload falsify SPEC`."""

from __future__ import annotations

import math
import shlex
from collections.abc import Callable
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import TYPE_CHECKING

from ..falsify.options import FALSIFY
from ..loop.defaults import FMU_DIR
from . import field_types as kinds
from .command_line import options_argv
from .errors import TiltloadError, as_tiltload_errors
from .field_types import closest_field

if TYPE_CHECKING:
    import pandas as pd



@closest_field
@dataclass(frozen=True, kw_only=True)
class FalsifyOptions:
    """How a search runs, field names as `tiltload falsify`'s options; None: the spec's own (optimizer, seed,
    simulations, seconds) or the default (out: runs/falsify/<name>-<optimizer>-<seed>; a local cluster)."""

    out: Path | None = None
    optimizer: str | None = None  # uniform, cmaes, tpe, neldermead
    seed: int | None = None  # the optimizer's
    simulations: int | None = None  # budget
    seconds: float | None = None  # wall-time budget
    scheduler: str | None = None
    workers: int | None = None
    fmus: Path = FMU_DIR
    no_early_stop: bool = False  # run every evaluation to the stop time
    branch: str = "auto"  # auto, on, off: evaluations branched from a snapshot
    neighbourhood: bool = False  # then a grid around the best case
    neighbourhood_fraction: float = 0.1
    neighbourhood_points: int | None = None

    def __post_init__(self) -> None:
        owner, fix = "FalsifyOptions", self._fix
        fix("out", kinds.path(owner, "out", self.out))
        fix("fmus", kinds.path(owner, "fmus", self.fmus, False))
        FALSIFY.choose("optimizer", kinds.text(owner, "optimizer", self.optimizer))  # falsify/options.py, as its parser
        FALSIFY.choose("branch", kinds.text(owner, "branch", self.branch, False))
        kinds.text(owner, "scheduler", self.scheduler)
        for name in ("seed", "simulations", "workers", "neighbourhood_points"):
            if fix(name, kinds.whole(owner, name, getattr(self, name))) is not None:
                FALSIFY.check(name, getattr(self, name))
        if fix("seconds", kinds.number(owner, "seconds", self.seconds)) is not None:
            fix("seconds", FALSIFY.check("seconds", self.seconds))
        fix("neighbourhood_fraction", kinds.number(owner, "neighbourhood_fraction", self.neighbourhood_fraction, False))
        fix("neighbourhood_fraction", FALSIFY.check("neighbourhood_fraction", self.neighbourhood_fraction))
        kinds.flag(owner, "no_early_stop", self.no_early_stop)
        kinds.flag(owner, "neighbourhood", self.neighbourhood)

    def _fix(self, name: str, value: object) -> object:
        object.__setattr__(self, name, value)  # frozen: normalized once, while built
        return value


@dataclass(frozen=True)
class FalsifyResult:
    """What a search found. falsified: a case with robustness < 0 was found (the first at evaluation falsified_at,
    0-based); best: the row of the lowest robustness (its inputs, robustness, verdicts); rows: every evaluation in the
    order asked; folder: the search's results (falsification.parquet, summary.txt, replay.sh); summary: summary.txt's
    text; command: the `tiltload falsify` line that makes (or resumes) the same search."""

    folder: Path
    rows: tuple[dict, ...]
    falsified_at: int | None
    best: dict | None
    seconds: float
    summary: str
    command: str

    @property
    def falsified(self) -> bool:
        return self.falsified_at is not None

    @property
    def simulations(self) -> int:
        return len(self.rows)

    @property
    def robustness(self) -> float:
        """The best (lowest) robustness found (inf: none scored)."""
        value = None if self.best is None else self.best.get("robustness")
        return math.inf if value is None else float(value)

    @property
    def results(self) -> Path:
        return self.folder / "falsification.parquet"

    def to_dataframe(self) -> pd.DataFrame:
        import pandas as pd

        return pd.read_parquet(self.results)


def run_falsification(spec: Path, options: FalsifyOptions, progress: Callable[[str], None] | None = None):
    """The core of `tiltload falsify SPEC` and tiltload.falsify: (the spec, the search's outcome, its folder).
    progress: where the search's lines go (default stderr). CampaignIncomplete when evaluations failed for their
    environment."""
    from ..batch.errors import ClusterError
    from ..falsify.runner import falsify as search
    from ..user_error import UserError
    from .campaigns import report_beside

    o = options
    report_beside(spec, o.out)
    try:
        found = search(Path(spec), o.out, o.fmus, o.optimizer, o.seed, o.simulations, o.seconds, o.scheduler, o.workers,
                       progress=progress, early_stop=not o.no_early_stop, branch=o.branch, neighbourhood=o.neighbourhood,
                       fraction=o.neighbourhood_fraction, points=o.neighbourhood_points)
    except ClusterError as err:
        raise UserError(str(err)) from None
    report(*found, o.fmus)
    return found


def report(spec, outcome, out: Path, fmus: Path) -> Path:
    """The search's report.html: its best case replayed with a log (as replay.sh runs it) and judged on it."""
    from ..falsify.report import REPLAY_OUT, SUMMARY, html_report, replay_case, replay_command, searched_fmus
    from .case import Case
    from .execute import execute
    from .run_options import RunOptions

    log, command = None, None
    if outcome.best is not None:
        command = replay_command(spec, outcome.best, out, fmus)
        fields = replay_case(spec, outcome.best, out, fmus)
        options = RunOptions(out=out / REPLAY_OUT[0], name=REPLAY_OUT[1], quiet=True, no_plots=True,
                             expect_fmu=searched_fmus(spec))
        try:
            with as_tiltload_errors():
                log = execute(Case(**fields), options, lambda line: None).log
        except TiltloadError:
            log = None  # the page says the case; its figures need the log
    text = (out / SUMMARY).read_text() if (out / SUMMARY).is_file() else ""
    return html_report(spec, outcome, out, command, text, log)


def falsify(spec: str | Path, options: FalsifyOptions | None = None, /, *, progress: Callable[[str], None] | None = None,
            **keywords: object) -> FalsifyResult:
    """Search a falsification spec's space (TOML/YAML: docs/falsification.md) for a case that breaks its requirements,
    as `tiltload falsify SPEC` does; options a FalsifyOptions or keywords (simulations=, optimizer=, seed=, out=,
    workers=, fmus=, ...). Resumes a search its folder holds. Raises TiltloadError for what the user can fix, and when
    evaluations failed for their environment (what was stored stays)."""
    from ..batch.errors import CampaignIncomplete
    from ..falsify.report import SUMMARY

    if not isinstance(spec, (str, Path)):
        raise TypeError(f"falsify() takes the spec's path (str or pathlib.Path), got {type(spec).__name__}")
    known = {f.name for f in fields(FalsifyOptions)}
    for key in keywords:
        if key not in known:
            raise TypeError(f"falsify() got an unexpected keyword argument {key!r}; the options are {', '.join(sorted(known))}")
    given = {k: v for k, v in keywords.items() if v is not None}
    with as_tiltload_errors():
        options = replace(options, **given) if options is not None else FalsifyOptions(**given)
        try:
            _, outcome, out = run_falsification(Path(spec), options, progress)
        except CampaignIncomplete as err:
            raise TiltloadError(str(err)) from None
    summary = (out / SUMMARY).read_text() if (out / SUMMARY).is_file() else ""
    return FalsifyResult(Path(out), tuple(outcome.rows), outcome.falsified_at, outcome.best, outcome.seconds, summary,
                         shlex.join(["tiltload", "falsify", Path(spec).as_posix(), *options_argv(options)]))

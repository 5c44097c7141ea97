"""tiltload.run: a Case run with its RunOptions by the same core as `tiltload run` (api/execute.py); keywords build the
same objects."""

from __future__ import annotations

import difflib
import sys
from collections.abc import Mapping
from dataclasses import fields, replace

from ..case.fields import CASE, RUN, Fields
from .case import Case
from .command_line import run_command
from .errors import TiltloadError, as_tiltload_errors
from .result import Result
from .run_options import RunOptions

_CASE = tuple(f.name for f in fields(Case))
_OPTIONS = tuple(f.name for f in fields(RunOptions))


def _unknown(key: str) -> TypeError:
    known = (*_CASE, *_OPTIONS, "progress", "echo")
    close = difflib.get_close_matches(key, known, n=1)
    return TypeError(f"run() got an unexpected keyword argument {key!r}"
                     + (f" (did you mean {close[0]!r}?)" if close else f"; the options are {', '.join(known)}"))


def _assignments(value: object, fields: Fields, name: str) -> object:
    """set= / remote= as the command line's texts ("plant.m_L=0.2", or a list of them): read as the command reads them."""
    if isinstance(value, str):
        value = [value]
    if isinstance(value, (list, tuple)) and all(isinstance(v, str) for v in value):
        return tuple(fields.check(name, v) for v in value)
    return value


def requests(case: Case | None, options: RunOptions | None, keywords: Mapping[str, object]) -> tuple[Case, RunOptions]:
    """The Case and RunOptions of run()'s arguments: keywords are their fields (None: the default), on top of the
    objects given."""
    for key in keywords:
        if key not in _CASE and key not in _OPTIONS:
            raise _unknown(key)
    if case is not None and not isinstance(case, Case):
        raise TypeError(f"run() takes a tiltload.Case first, got {type(case).__name__}")
    if options is not None and not isinstance(options, RunOptions):
        raise TypeError(f"run() takes tiltload.RunOptions second, got {type(options).__name__}")
    given = {k: v for k, v in keywords.items() if v is not None}
    if "set" in given:
        given["set"] = _assignments(given["set"], CASE, "set")
    if "expect_fmu" in given:
        given["expect_fmu"] = _assignments(given["expect_fmu"], RUN, "expect_fmu")
    if "remote" in given:
        given["remote"] = _assignments(given["remote"], CASE, "remote")
    if given.get("realtime") is False:
        del given["realtime"]
    if isinstance(given.get("snapshot_at"), list):
        given["snapshot_at"] = tuple(given["snapshot_at"])
    case_keys = {k: v for k, v in given.items() if k in _CASE}
    option_keys = {k: v for k, v in given.items() if k in _OPTIONS}
    case = replace(case, **case_keys) if case is not None else Case(**case_keys)
    options = replace(options, **option_keys) if options is not None else RunOptions(**option_keys)
    return case, options


def command_line(case: Case, options: RunOptions) -> str:
    """The `tiltload run` command that makes the same run (quiet aside: it changes no run)."""
    return run_command(case, options)


def run(case: Case | None = None, options: RunOptions | None = None, /, *, progress: bool | None = None,
        echo: bool = False, pool=None, **keywords: object) -> Result:
    """Run a case as `tiltload run` does: ``run(Case(scenario="lkf", stop_time=5), RunOptions(no_plots=True))``, or
    the same as keywords, ``run(scenario="lkf", stop_time=5, no_plots=True)`` (keywords also change the objects given).

    requirements: a requirement file monitored while the run goes (``result.requirements``, ``result.verdicts``); a
    FAIL does not raise (assert on it, or use tiltload.testing.assert_requirements_hold).
    progress: the terminal's progress bar (default: only if stderr is a terminal, so never in Jupyter).
    echo: print the lines the command prints (they are in ``result.transcript`` either way).
    pool: for a harness that runs many cases (the pytest plugin's session): an engine ExecutionPool keeping the FMU
    instances between runs, a run of the same structure restarting them (fmi2Reset) instead of loading them again.
    Raises TiltloadError for what the user can fix (its message the command's one line), TypeError for a wrong type
    or an unknown keyword, KeyboardInterrupt if interrupted (the log is finalized first)."""
    from . import field_types as kinds
    from .execute import execute, preparing

    if progress is not None:
        kinds.flag("run()", "progress", progress)
    kinds.flag("run()", "echo", echo)
    with as_tiltload_errors():
        case, options = requests(case, options, keywords)
    if not (sys.stderr.isatty() if progress is None else progress):
        options = replace(options, quiet=True)
    lines: list[str] = []

    def say(line: str) -> None:
        lines.append(line)
        if echo:
            print(line, flush=True)
    if not options.quiet:
        say(preparing(case, options))
    with as_tiltload_errors():
        outcome = execute(case, options, say, pool)
    if outcome.failure is not None:
        if outcome.result.signal == 2:
            raise KeyboardInterrupt(outcome.failure)
        raise TiltloadError(outcome.failure)
    res = outcome.result
    return Result(fmus=_recorded_fmus(outcome.log), metrics={k: float(v) for k, v in res.metrics.items()}, case=case, options=options,
                  record={k: str(v) for k, v in outcome.metadata.items()}, log=outcome.log, command=command_line(case, options),
                  stop_time=float(outcome.metadata["stop_time"]), sim_time=res.sim_time, wall_time=res.wall, ticks=res.ticks,
                  plots=tuple(outcome.plots), transcript="".join(f"{line}\n" for line in lines),
                  requirements=tuple(outcome.requirements), profile=res.profile)


def _recorded_fmus(log) -> tuple:
    """The FMUs the run's log records (the same record tiltload.open_log reads); none without a log."""
    if log is None or not log.is_file():
        return ()
    from ...engine.log.reader import read_metadata
    from ..case.record import fmus_of_metadata

    fmus = read_metadata(log).get("fmus", {})
    return fmus_of_metadata(fmus if isinstance(fmus, dict) else {})[0]

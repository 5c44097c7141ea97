"""tiltload.run: `tiltload run` from Python, the same options as keywords and the same code underneath."""

from __future__ import annotations

import io
import sys
from contextlib import redirect_stdout
from typing import TextIO

from . import keywords
from .errors import TiltloadError, as_tiltload_errors
from .result import Result


class _Tee(io.TextIOBase):
    """Writes to a buffer and to a stream (echo=True)."""

    def __init__(self, buffer: io.StringIO, stream: TextIO) -> None:
        self.buffer_, self.stream = buffer, stream

    def write(self, text: str) -> int:
        self.stream.write(text)
        return self.buffer_.write(text)

    def flush(self) -> None:
        self.stream.flush()


def run(*, progress: bool | None = None, echo: bool = False, **options: object) -> Result:
    """Run the loop as `tiltload run` does with the same options, given as keywords: ``--stop-time 5`` is
    ``stop_time=5``, a flag is ``True``, ``--set`` takes a mapping (``set={"plant.m_L": 0.2}``).

    requirements: a requirement file monitored while the run goes (``result.requirements``, ``result.verdicts``); a
    FAIL does not raise (assert on it, or use tiltload.testing.assert_requirements_hold).
    progress: the terminal's progress bar (default: only if stderr is a terminal, so never in Jupyter).
    echo: print what the command prints (it is in ``result.transcript`` either way).
    Raises TiltloadError for what the user can fix (its message the command's one line), TypeError for an unknown
    keyword, KeyboardInterrupt if interrupted (the log is finalized first)."""
    from ..commands.run import execute

    argv = keywords.to_argv("run", options, "run")
    args = keywords.parse("run", argv)
    if not (sys.stderr.isatty() if progress is None else progress):
        args.quiet = True
    out = io.StringIO()
    with redirect_stdout(_Tee(out, sys.stdout) if echo else out), as_tiltload_errors():
        outcome = execute(args)
    if outcome.failure is not None:
        if outcome.result.signal == 2:
            raise KeyboardInterrupt(outcome.failure)
        raise TiltloadError(outcome.failure)
    res = outcome.result
    return Result(metrics=dict(res.metrics), case={k: str(v) for k, v in outcome.metadata.items()}, log=outcome.log,
                  command=keywords.command_line("run", argv), options=dict(options),
                  stop_time=float(outcome.metadata["stop_time"]), sim_time=res.sim_time, wall_time=res.wall, ticks=res.ticks,
                  plots=tuple(outcome.plots), transcript=out.getvalue(), requirements=outcome.requirements)

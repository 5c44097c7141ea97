"""The one table of the errors a run, a command or an API call can end in, read by every face: the `tiltload` command
(cli.main: its line on stderr and its exit code), the API (api/errors.as_tiltload_errors: TiltloadError with that
line), the pytest plugin and the reports (the same line). docs/exit_codes.md lists the codes."""

from __future__ import annotations

from dataclasses import dataclass

from ...controller_fmu.design.error_dynamics import DesignError
from ...native_fmu.compile import BuildError
from ...scenario_fmu.files import ScenarioFileError
from ..engine.errors import DescriptionError
from ..engine.user_files import UserFileError
from .campaign.report import ReportError
from .case.spec_file import SpecError
from .feasibility.policy import InfeasibleReference
from .user_error import TiltloadError, UserError, one_line
from .wrap.wrap import WrapError


@dataclass(frozen=True)
class ErrorKind:
    """A kind of error: what it is, the classes that raise it, the exit code, whether the user can fix it, and how its
    one line begins (the error's own message follows)."""

    name: str
    classes: tuple[type[BaseException], ...]
    exit_code: int
    users_to_fix: bool
    prefix: str = ""


# the kinds in the order they are matched (a class under two kinds takes the first); the first two are the user's
KINDS = (
    ErrorKind("a request the API or a parser refused", (TiltloadError,), 2, True),
    # a bad option, file, description, spec, design, report, class to wrap, trajectory or wind file (or any file the
    # input layer refused), a reference the vehicle cannot fly: every message is a complete line for the user
    ErrorKind("input the user can fix", (UserError, DescriptionError, SpecError, ReportError, WrapError, DesignError,
                                         ScenarioFileError, InfeasibleReference, UserFileError), 2, True),
    ErrorKind("a build that failed (a compiler missing or failing)", (BuildError,), 1, False, "building the FMUs failed: "),
)
USER_ERRORS = tuple(c for kind in KINDS if kind.users_to_fix and kind.classes != (TiltloadError,) for c in kind.classes)


def kind_of(err: BaseException) -> ErrorKind | None:
    """The kind of an error (None: none of the table's: a bug)."""
    return next((k for k in KINDS if isinstance(err, k.classes)), None)


def line_of(err: BaseException) -> str:
    """The line the command prints for an error of the table (a TiltloadError's own: the command's parser's line)."""
    if isinstance(err, TiltloadError):
        return err.cli_line
    kind = kind_of(err)
    return f"tiltload: error: {kind.prefix if kind else ''}{one_line(str(err))}"


def failure_line(error: str, log, sim_time: float) -> str:
    """How a run ended early and where its log stands, in one line."""
    if log is None:
        where = "no log (--no-log)"
    elif log.is_file():
        where = f"the log is readable up to t = {sim_time:.3f} s"
    else:
        where = "no log was written"
    return f"{error}; {where}"


def run_failed(error: str, signal: int | None, log, sim_time: float) -> int:
    """Say how a run ended early and where its log stands; the exit code (128 + signal, or 1)."""
    import sys

    print(f"tiltload: error: {failure_line(error, log, sim_time)}", file=sys.stderr)
    return 128 + signal if signal else 1

"""What the `tiltload` command reports as the user's to fix (one line, exit 2), gathered in one place."""

from __future__ import annotations

from ...controller_fmu.design.error_dynamics import DesignError
from ...scenario_fmu.files import ScenarioFileError
from ..engine.errors import DescriptionError
from ..engine.user_files import UserFileError
from .campaign.report import ReportError
from .case.spec_file import SpecError
from .feasibility.policy import InfeasibleReference
from .user_error import UserError
from .wrap.wrap import WrapError

# every error whose message is a complete line for the user: a bad option, file, description, spec or design, a trajectory
# or wind file (or any file the input layer refused), a reference the vehicle cannot fly
USER_ERRORS = (UserError, DescriptionError, SpecError, ReportError, WrapError, DesignError, ScenarioFileError,
               InfeasibleReference, UserFileError)


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

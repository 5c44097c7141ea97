"""The engine's two failures: a description that cannot run, and a run that failed. Both carry one line for the user."""

from __future__ import annotations


class DescriptionError(ValueError):
    """A malformed or inconsistent system description, or an FMU that does not fit it; the message names the part.
    Raised before the first step."""


class ExecutionError(RuntimeError):
    """A failure while running; the message names the instance, the call and the FMU's own words."""

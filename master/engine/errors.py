"""The engine's two failures: a description that cannot run, and a run that failed. Both carry one line for the user."""

from __future__ import annotations


class DescriptionError(ValueError):
    """A malformed or inconsistent system description, or an FMU that does not fit it; the message names the part.
    Raised before the first step."""


class ExecutionError(RuntimeError):
    """A failure while running; the message names the instance, the call and the FMU's own words."""


class FmuEndedRun(Exception):
    """Not a failure: an FMU asked to end the simulation (FMI 2.0 fmi2Discard with fmi2Terminated, FMI 3.0
    terminateSimulation from doStep) at `time`; its outputs there are valid (docs/master.md, "Signals at a run's edges")."""

    def __init__(self, instance: str, time: float, failure: BaseException | None = None) -> None:
        super().__init__(f"{instance} ended the run at t = {time:.6g} s")
        self.instance, self.time = instance, time
        self.failure = failure or ExecutionError(f"{instance}: the FMU asked to terminate the simulation at t={time:.6g} s")
        # what the request is where a system takes it as a failure (System.fmu_end "error"; an FMU hosted elsewhere)

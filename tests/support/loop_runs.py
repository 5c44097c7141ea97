"""One run of the thesis loop for a process pool: its metrics (importable by the spawned workers)."""

from __future__ import annotations

from pathlib import Path


def case_metrics(fmus: str, scenario: str, trajectory: int, controller: str, fmi: int = 2, clocked: bool = False) -> dict:
    """Seed 1, the trajectory's full length, no log: the metrics of a reproduction case on one FMU set."""
    from tiltload.master.app.loop.thesis import default_stop, default_system, loop_metrics
    from tiltload.master.app.regression.reproduce import SEED
    from tiltload.master.engine.run import run_system

    system = default_system(Path(fmus), scenario, trajectory, controller, SEED, fmi=fmi, clocked=clocked)
    result = run_system(system, default_stop(trajectory), None, loop_metrics(), progress=False)
    assert result.error is None, result.error
    return result.metrics

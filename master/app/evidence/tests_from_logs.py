"""A report's test from a run's log: its case (the log's "run" record), the command that replays it, its metrics,
and the requirements judged on it."""

from __future__ import annotations

from pathlib import Path

from ..case.record import metrics_of_metadata, replay_command
from .model import Test, environment_of_log


def test_of_log(log: Path, results, requirements: Path | None = None, name: str | None = None) -> Test:
    """The test a log stands for: named by its file, its case and metrics from its metadata, the results given
    (engine.requirement.check.Result), the one line of the error that ended its run, if one did."""
    from ...engine.log.reader import read_metadata

    meta = read_metadata(Path(log))
    run = dict(meta.get("run", {}))
    metrics, _ = metrics_of_metadata(meta)
    error = meta.get("error", {}).get("message") if isinstance(meta.get("error"), dict) else None
    return Test(name or Path(log).stem, replay_command(run, requirements), run, Path(log), list(results), metrics, error,
                environment=environment_of_log(meta))

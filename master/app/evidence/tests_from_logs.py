"""A report's test from a run's log: its case (the log's "run" record), the command that replays it, its metrics,
and the requirements judged on it."""

from __future__ import annotations

import shlex
from pathlib import Path

from .model import Test, environment_of_log

# "run" record key -> the `tiltload run` option that sets it (flags: the value that turns them on)
_OPTIONS = (("vehicle", "--vehicle"), ("scenario", "--scenario"), ("trajectory", "--trajectory"),
            ("controller", "--controller"), ("seed", "--seed"), ("stop_time", "--stop-time"), ("faults", "--faults"),
            ("wind", "--wind"), ("schedule", "--schedule"), ("fmi", "--fmi"))
_FLAGS = (("delay", "True", "--delay"), ("gusts", "False", "--no-gusts"), ("clocks", "True", "--clocks"))


def replay_command(run: dict, requirements: Path | None = None) -> str:
    """The `tiltload run` command line of a log's "run" record, runnable as printed (a user's controller FMU by the
    path the run was given); empty for a record that names no case."""
    if run.get("system"):
        argv = ["tiltload", "run", "--system", str(run["system"]), "--stop-time", str(run.get("stop_time", ""))]
        if run.get("faults"):
            argv += ["--faults", str(run["faults"])]
    elif "scenario" in run:
        argv = ["tiltload", "run"]
        for key, option in _OPTIONS:
            value = run.get(key)
            if value not in (None, "") and not (key == "fmi" and str(value) == "2") and not (key == "vehicle" and value == "load"):
                argv += [option, str(value)]
        argv += [flag for key, on, flag in _FLAGS if str(run.get(key, "")) == on]
        for setting in str(run.get("set", "")).split():
            argv += ["--set", setting]
    else:
        return ""
    if requirements is not None:
        argv += ["--requirements", str(requirements)]
    return shlex.join(argv)


def test_of_log(log: Path, results, requirements: Path | None = None, name: str | None = None) -> Test:
    """The test a log stands for: named by its file, its case and metrics from its metadata, the results given
    (engine.requirement.check.Result), the one line of the error that ended its run, if one did."""
    from ...engine.log.reader import read_metadata

    meta = read_metadata(Path(log))
    run = dict(meta.get("run", {}))
    metrics = {}
    for key, value in meta.get("metrics", {}).items():
        try:
            metrics[key] = float(value)
        except ValueError:
            continue
    metrics = {k: v for k, v in metrics.items() if k not in ("ticks", "complete")}
    error = meta.get("error", {}).get("message") if isinstance(meta.get("error"), dict) else None
    return Test(name or Path(log).stem, replay_command(run, requirements), run, Path(log), list(results), metrics, error,
                environment=environment_of_log(meta))

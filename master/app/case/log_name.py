"""The default name of a run's log: every option that changes the run (or what its log holds) changes the name, so a
run never replaces the log of another. The loop's options name themselves (options.LoopOptions.run_name); this adds
what `tiltload run` decides beyond them. tests/app/test_log_names.py walks every option of `tiltload run`."""

from __future__ import annotations

import argparse

from .options import LoopOptions, file_safe


def default_log_name(args: argparse.Namespace, opts: LoopOptions, natural_stop: float | None,
                     own_schedule: str | None = None, resumed_at: float | None = None, schedule: str | None = None) -> str:
    """opts.run_name, then: a schedule other than the system's own (jacobi), real-time pacing (and its overrun
    limit), a log of every N-th step, requirements monitored (and a run stopped at their first FAIL), a snapshot
    taken, a run continued from a snapshot at resumed_at. args: the command's options (or the API's RunOptions);
    schedule: the one asked for, if args has none (the API's is the Case's)."""
    parts = [opts.run_name(natural_stop)]
    schedule = schedule or getattr(args, "schedule", None)
    if schedule is not None and schedule != (own_schedule or "ordered"):
        parts.append(schedule)
    if getattr(args, "realtime", None) is not None:  # paced: the log holds the overrun statistics, a limit may stop it
        parts.append(f"rt{args.realtime:g}x")
        if args.max_overruns is not None:
            parts.append(f"max{args.max_overruns}overruns")
    if getattr(args, "log_every", 1) != 1:
        parts.append(f"every{args.log_every}")
    if getattr(args, "requirements", None) is not None:  # the log holds /requirements; stopping at a FAIL cuts the run
        parts.append(f"req-{args.requirements.stem}" + ("-stoponfail" if getattr(args, "stop_on_violation", False) else ""))
    if getattr(args, "snapshot_at", None) is not None:
        parts.append(f"snap{args.snapshot_at[0]}s")
    if resumed_at is not None:
        parts.append(f"from{resumed_at:g}s")
    return file_safe("_".join(parts))

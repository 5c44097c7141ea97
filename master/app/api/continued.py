"""A run continued from a snapshot: the loop options it was taken with, checked against what the case and the options
say again (the files it names, where each instance runs), with this run's faults, stop time and --set instead."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from ..user_error import UserError
from .case import Case
from .run_options import RunOptions

# the options that say which loop runs: a run continued from a snapshot takes them from the snapshot
# (their defaults: None or False, so a given option is one that is neither)
LOOP_DEFINING = ("vehicle", "scenario", "trajectory", "controller", "seed", "delay", "no_gusts", "system", "schedule",
                 "allow_unknown_inputs", "wind", "fmi", "clocks")
# files the snapshot names but never locates: the command line gives them again, and their digests are checked
NAMED_FILES = {"controller": "controller_fmu", "system": "system"}


def _refuse(given: list[str]) -> None:
    if given:
        raise UserError(f"--from-snapshot: {', '.join(given)} cannot change in a continued run (the snapshot says "
                        "which loop it is; --faults, --set of tunable parameters and --stop-time can)")


def continued(case: Case, options: RunOptions):
    """(snapshot, the loop options it was taken with, this run's faults and stop time instead of its own).
    A snapshot is data: its FMUs are those of the case's folder (fmus, default fmus/), and a controller FMU or system
    file of the user's is the one the case names again; snapshot.check compares each with the digests recorded before
    anything is loaded."""
    from ...engine import snapshot
    from ..arguments import DEFAULT_FMU_DIR
    from ..case.options import snapshot_options

    path = options.from_snapshot
    _refuse([f"--{k.replace('_', '-')}" for k in LOOP_DEFINING if getattr(case, k) not in (None, False)
             and k not in NAMED_FILES])  # before the file is read; --controller and --system once it says which it needs
    if options.snapshot_at is not None:
        raise UserError("--from-snapshot and --snapshot-at together: continue first, then take a new snapshot in a later run")
    snap = snapshot.read(path)
    opts = snapshot_options(snap.application, path)
    stop, schedule = snap.application.get("stop"), snap.application.get("schedule")
    if not (stop is None or (isinstance(stop, (int, float)) and not isinstance(stop, bool) and 0 < stop < float("inf"))):
        raise UserError(f"{path}: its stop time is not a positive number of seconds ({stop!r})")
    if schedule not in (None, "ordered", "jacobi"):
        raise UserError(f"{path}: its schedule {str(schedule)[:40]!r} is neither ordered nor jacobi")
    needed = {flag: getattr(opts, field) for flag, field in NAMED_FILES.items() if getattr(opts, field) is not None}
    _refuse([f"--{k}" for k in NAMED_FILES if getattr(case, k) is not None and k not in needed])
    for flag, recorded in needed.items():
        given = getattr(case, flag)
        if given is None:
            raise UserError(f"--from-snapshot {path}: it was taken with the {flag} file {Path(recorded).name}: "
                            f"name it again with --{flag} PATH (a snapshot never says where files are; its digest is checked)")
        if not Path(given).is_file():
            raise UserError(f"--{flag} {given}: no such file")
        opts = dataclasses.replace(opts, **({"controller": str(given), "controller_fmu": Path(given)} if flag == "controller"
                                            else {"system": Path(given)}))
    _same_places(dict(opts.remotes), dict(case.remote), path)
    opts = dataclasses.replace(opts, faults=case.faults if case.faults is not None else opts.faults,
                               fmus=case.fmus or DEFAULT_FMU_DIR, stop_time=case.stop_time or stop or opts.stop_time,
                               remotes=tuple(case.remote))  # where an instance runs is this run's, not the snapshot's
    branch: dict[str, dict] = {}
    for key, value in case.set:
        instance, _, name = key.partition(".")
        branch.setdefault(instance, {})[name] = value
    snap.settings = branch
    return snap, opts


def _same_places(then: dict[str, str], now: dict[str, str], path: Path) -> None:
    """An FMU's serialized state is its machine's (a library built elsewhere may lay its memory out otherwise): a run
    continues with each instance where it ran when the snapshot was taken, on a tiltload serve or here (the server's
    address may change)."""
    for name in sorted(set(then) ^ set(now)):
        if name in then:
            raise UserError(f"--from-snapshot {path}: {name} ran on tiltload serve at {then[name]} when it was taken, and "
                            f"its state is that machine's: continue with --remote {name}=HOST:PORT")
        raise UserError(f"--from-snapshot {path}: {name} ran in this master's machine when it was taken, and its state "
                        f"is this machine's: continue without --remote {name}")

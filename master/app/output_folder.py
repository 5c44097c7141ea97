"""The folder a command writes its results into (campaign, falsify, campaign-report), checked before any work starts:
a folder (made if missing) that can be written, on a disk with room. One line for each way it is not (exit 2), so a
cluster is never started for results that could not be stored.
"""

from __future__ import annotations

import errno
import os
import shutil
from pathlib import Path

from ..command_line.path_types import folder_problem
from .user_error import UserError

MIN_FREE = 16 * 2**20  # bytes: a part of a campaign is kilobytes, its results and report a few megabytes


def _free(path: Path) -> int | None:
    try:
        return shutil.disk_usage(path).free
    except OSError:
        return None


def writable_folder(path: Path, what: str, min_free: int = MIN_FREE) -> Path:
    """path, if it is a folder this process can write files into, or one it could make (its nearest existing ancestor
    is such a folder), with at least min_free bytes free on its disk; else UserError naming the folder and the problem.
    Nothing is made: the command makes the folder when it first writes (after its other checks). what: the option."""
    path = Path(path)
    problem = folder_problem(path)
    if problem is not None:
        raise UserError(f"{what} {problem}")
    existing = next(p for p in (path, *path.parents, Path(".")) if p.exists())
    probe = existing / f".tiltload-probe-{os.getpid()}"
    try:
        with open(probe, "wb") as f:  # a real write: a read-only mount or a folder of another user refuses it here
            f.write(b"\0" * 4096)
            f.flush()
            os.fsync(f.fileno())
    except OSError as err:
        reason = {errno.EACCES: "permission denied", errno.EPERM: "permission denied", errno.EROFS: "on a read-only disk",
                  errno.ENOSPC: "its disk is full", errno.EDQUOT: "its disk quota is used up"}.get(err.errno,
                                                                                              err.strerror or str(err))
        raise UserError(f"{what} {path} cannot be written: {reason}") from None
    finally:
        try:
            probe.unlink(missing_ok=True)
        except OSError:
            pass
    free = _free(existing)
    if free is not None and free < min_free:
        raise UserError(f"{what} {path}: its disk has {free // 1024} KiB free, less than the {min_free // 2**20} MiB the "
                        "results need: make room or choose another --out")
    return path

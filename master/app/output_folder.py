"""The folder a command writes its results into (campaign, falsify, campaign-report), checked before any work starts:
a folder (made if missing) that can be written, on a disk with room. One line for each way it is not (exit 2), so a
cluster is never started for results that could not be stored.
"""

from __future__ import annotations

import errno
import os
import shutil
from pathlib import Path

from .user_error import UserError

MIN_FREE = 16 * 2**20  # bytes: a part of a campaign is kilobytes, its results and report a few megabytes


def _blocker(path: Path) -> Path | None:
    """The nearest existing ancestor of path (path itself included) that is not a folder: nothing can be made under it."""
    for p in (path, *path.parents):
        if p.exists() or p.is_symlink():
            return None if p.is_dir() else p
    return None


def _free(path: Path) -> int | None:
    try:
        return shutil.disk_usage(path).free
    except OSError:
        return None


def writable_folder(path: Path, what: str, min_free: int = MIN_FREE) -> Path:
    """path as a folder this process can write files into (made, with its parents, if missing), with at least min_free
    bytes free on its disk; else UserError naming the folder and the problem. what: the option or role ("--out")."""
    path = Path(path)
    blocker = _blocker(path)
    if blocker == path:
        raise UserError(f"{what} {path} is a file, not a folder")
    if blocker is not None:
        raise UserError(f"{what} {path}: {blocker} is a file, so no folder can be made under it")
    try:
        path.mkdir(parents=True, exist_ok=True)
        probe = path / f".tiltload-probe-{os.getpid()}"
        with open(probe, "wb") as f:  # a real write: a read-only mount or a folder of another user refuses it here
            f.write(b"\0" * 4096)
            f.flush()
            os.fsync(f.fileno())
        probe.unlink()
    except OSError as err:
        reason = {errno.EACCES: "permission denied", errno.EPERM: "permission denied", errno.EROFS: "on a read-only disk",
                  errno.ENOSPC: "its disk is full", errno.EDQUOT: "its disk quota is used up"}.get(err.errno,
                                                                                              err.strerror or str(err))
        try:
            (path / f".tiltload-probe-{os.getpid()}").unlink(missing_ok=True)
        except OSError:
            pass
        raise UserError(f"{what} {path} cannot be written: {reason}") from None
    free = _free(path)
    if free is not None and free < min_free:
        raise UserError(f"{what} {path}: its disk has {free // 1024} KiB free, less than the {min_free // 2**20} MiB the "
                        "results need: make room or choose another --out")
    return path

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
        raise UserError(f"{what} {path} cannot be written: {_reason(err)}") from None
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


def same_file(a: Path, b: Path) -> bool:
    """a and b are one file: the same inode (a hard link, a symbolic link, another spelling of the path), or, where
    one is missing, the same resolved path."""
    try:
        return os.path.samefile(a, b)
    except OSError:
        return Path(a).resolve() == Path(b).resolve()


def writable_file(path: Path, what: str, inputs: dict[str, Path | None] | list[tuple[str, Path | None]] | None = None) -> Path:
    """path, if a file can be written there: what output_file says (not a folder, a FIFO, a device, nor under a file),
    its folder one that can be written (writable_folder) and none of the command's inputs (inputs: {"the log it
    judges": path}; written over, the input would be lost). Else UserError, one line. what: the option ("--report")."""
    import argparse

    from ..command_line.path_types import output_file

    path = Path(path)
    try:
        output_file(str(path))
    except argparse.ArgumentTypeError as err:
        raise UserError(f"{what}: {err}") from None
    for role, given in inputs.items() if isinstance(inputs, dict) else inputs or ():
        if given is not None and same_file(path, Path(given)):  # one not made yet (the run's log) by its path
            raise UserError(f"{what} {path} is {role} ({given}): refused, it would be written over")
    writable_folder(path.parent if str(path.parent) else Path("."), f"{what}: the folder of", min_free=0)
    return path


def _reason(err: OSError) -> str:
    return {errno.EACCES: "permission denied", errno.EPERM: "permission denied", errno.EROFS: "on a read-only disk",
            errno.ENOSPC: "its disk is full", errno.EDQUOT: "its disk quota is used up"}.get(err.errno, err.strerror or str(err))


def write_file(path: Path, content: str | bytes) -> Path:
    """content written at path whole or not at all (a .part beside it, then renamed), its folder made as needed;
    a write the disk refuses after the checks (it filled up meanwhile) is one UserError line, the .part removed."""
    path = Path(path)
    part = path.with_name(path.name + ".part")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        if isinstance(content, str):
            part.write_text(content, encoding="utf-8")
        else:
            part.write_bytes(content)
        part.replace(path)
    except OSError as err:
        part.unlink(missing_ok=True)
        raise UserError(f"{path} cannot be written: {_reason(err)}") from None
    return path

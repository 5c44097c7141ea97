"""Path options of every command line (`tiltload`, and `tiltload serve` alone on a board): what the path is, said in
one line when it cannot be what the option needs, before the command prepares anything. Standard library only.

- folder: a folder, or a path where one can be made (outputs, --fmus that builds);
- existing_folder: a folder that is there (serve's --fmus: it only reads);
- output_file: a path a file can be written at (not a folder, not under a file).
"""

from __future__ import annotations

import argparse
import stat
from pathlib import Path


def kind(path: Path) -> str | None:
    """What path is ("a file", "a folder", "a FIFO", ...), or None if nothing is there."""
    try:
        mode = Path(path).stat().st_mode
    except (FileNotFoundError, NotADirectoryError):  # nothing there (under a file: the caller names that file)
        return None
    except OSError:  # a broken link, a loop: something is there that is neither
        return "an unreadable path"
    for test, name in ((stat.S_ISDIR, "a folder"), (stat.S_ISREG, "a file"), (stat.S_ISFIFO, "a FIFO"),
                       (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return name
    return "not a file"


def _blocker(path: Path) -> Path | None:
    """The nearest existing ancestor of path (path itself included) that is not a folder: nothing can be made under it."""
    for p in (path, *path.parents):
        if p.exists() or p.is_symlink():
            return None if p.is_dir() else p
    return None


def folder_problem(path: Path) -> str | None:
    """Why path cannot be (or become) a folder: it is a file (or a FIFO, a device...), or lies under one; None if it can."""
    path = Path(path)
    blocker = _blocker(path)
    if blocker == path:
        return f"{path} is {kind(path) or 'a broken link'}, not a folder"
    if blocker is not None:
        return f"{path}: {blocker} is {kind(blocker) or 'a broken link'}, so no folder can be made under it"
    return None


def folder(text: str) -> Path:
    """An argparse type: a folder, or a path where one can be made."""
    problem = folder_problem(Path(text)) if text else "an empty path"
    if problem is not None:
        raise argparse.ArgumentTypeError(problem)
    return Path(text)


def existing_folder(text: str) -> Path:
    """An argparse type: a folder that is there."""
    path = Path(text)
    what = kind(path) if text else None
    if not text:
        raise argparse.ArgumentTypeError("an empty path")
    if what is None:
        blocker = _blocker(path)
        raise argparse.ArgumentTypeError(f"{path}: {blocker} is {kind(blocker)}, not a folder" if blocker is not None
                                          else f"{path}: no such folder")
    if what != "a folder":
        raise argparse.ArgumentTypeError(f"{path} is {what}, not a folder")
    return path


def output_file(text: str) -> Path:
    """An argparse type: a path a file can be written at: not a folder, nor under a file (a missing folder above it is
    made by the command)."""
    path = Path(text)
    if not text:
        raise argparse.ArgumentTypeError("an empty path")
    what = kind(path)
    if what == "a folder":
        raise argparse.ArgumentTypeError(f"{path} is a folder, not a file: name the file to write in it")
    if what not in (None, "a file"):
        raise argparse.ArgumentTypeError(f"{path} is {what}, not a file")
    blocker = _blocker(path.parent)
    if blocker is not None:
        raise argparse.ArgumentTypeError(f"{path}: {blocker} is {kind(blocker)}, so no file can be made under it")
    return path

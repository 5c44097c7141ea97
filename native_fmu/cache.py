"""The machine's tiltload cache: designs, compiled libraries and the FMUs built, each under its content's digest, so a
second working folder or a second clone reuses them."""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path


def cache_root() -> Path:
    """$TILTLOAD_CACHE, else $XDG_CACHE_HOME/tiltload or ~/.cache/tiltload."""
    root = os.environ.get("TILTLOAD_CACHE") or Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "tiltload"
    return Path(root)


def cached_fmu(fmu_name: str, digest: str) -> Path:
    """Where the FMU built from the inputs of `digest` is kept on this machine (a file there may not exist yet)."""
    return cache_root() / "fmus" / digest[:32] / fmu_name


def newest_cached(fmu_name: str) -> Path | None:
    """The machine's latest build of an FMU of this name, whatever its inputs (None: none, or no cache to read)."""
    try:
        found = [(p.stat().st_mtime_ns, p) for p in (cache_root() / "fmus").glob(f"*/{fmu_name}") if p.is_file()]
    except OSError:
        return None
    return max(found, default=(0, None))[1]


def keep(built: Path, digest: str) -> None:
    """Copy a build into the machine's cache (atomically: a reader sees the whole file or none). A cache that cannot be
    written (a read-only home, a full disk) only costs the next folder a build."""
    target = cached_fmu(built.name, digest)
    part = None
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        fd, part = tempfile.mkstemp(dir=target.parent, prefix=".part-")
        os.close(fd)
        shutil.copyfile(built, part)
        os.replace(part, target)
    except OSError:
        if part is not None:
            Path(part).unlink(missing_ok=True)


def fetch(fmu_name: str, digest: str, target: Path) -> bool:
    """Copy the cached build of `digest` to target, if the machine has one; True if it did."""
    source = cached_fmu(fmu_name, digest)
    if not source.is_file():
        return False
    target.parent.mkdir(parents=True, exist_ok=True)
    part = target.with_name(target.name + ".part")
    shutil.copyfile(source, part)
    os.replace(part, target)
    return True

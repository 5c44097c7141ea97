"""An untrusted zip archive unpacked once into a folder named by its content, within limits (members, total size,
expansion ratio), whole or not at all; as libcosim keeps utility/zip apart from its SSP loader."""

from __future__ import annotations

import hashlib
import os
import threading
import zipfile
from pathlib import Path

from ..errors import DescriptionError

# Limits on what an archive may unpack to: a package holds a few FMUs (the loop's is 0.45 MB; a big FMU with its
# resources, hundreds of MB), a zip bomb expands a thousandfold. Checked on the declared sizes before anything is
# written, and again on the bytes actually written (a declared size can lie).
MAX_UNPACKED = 1 << 30  # 1 GiB unpacked in all
MAX_RATIO = 100  # a member may expand at most 100-fold (the loop's SSD: 16-fold; FMUs hardly) ...
RATIO_FREE = 1 << 20  # ... unless it unpacks to at most 1 MiB
MAX_MEMBERS = 10_000
_BLOCK = 1 << 20


def package_digest(path: Path) -> str:
    """The archive's SHA-256, read in blocks (a large package is never held in memory)."""
    with open(path, "rb") as f:
        return hashlib.file_digest(f, "sha256").hexdigest()


def unpack(path: Path, into: Path) -> Path:
    """The archive unpacked once into the folder into (FMUs are loaded from files), keyed by its content.

    Refused with one line, leaving nothing behind: a link or any other non-regular member, a name that leaves the
    package, more than MAX_MEMBERS members, more than MAX_UNPACKED bytes in all, a member that expands more than
    MAX_RATIO-fold (above RATIO_FREE bytes)."""
    import shutil

    folder = Path(into) / package_digest(path)[:20]
    if (folder / ".complete").exists():
        return folder
    partial = folder.with_name(f"{folder.name}.{os.getpid()}.{threading.get_ident()}.partial")  # one per unpacker
    shutil.rmtree(partial, ignore_errors=True)
    try:
        with zipfile.ZipFile(path) as z:
            members = _checked_members(path, z)
            partial.mkdir(parents=True)
            written = 0
            for info in members:
                target = partial / info.filename
                if info.is_dir():
                    target.mkdir(parents=True, exist_ok=True)
                    continue
                target.parent.mkdir(parents=True, exist_ok=True)
                written += _copy_member(path, z, info, target, MAX_UNPACKED - written)
        (partial / ".complete").write_text("")
        try:
            partial.rename(folder)  # fails if the folder is there: published by another unpacker, or a crash's leftover
        except OSError:
            if (folder / ".complete").exists():  # another process or thread unpacked the same package meanwhile
                shutil.rmtree(partial, ignore_errors=True)
            else:  # a folder without its mark is left from an unpacker that died; nobody else uses it
                shutil.rmtree(folder, ignore_errors=True)
                partial.rename(folder)
    except BaseException as err:
        shutil.rmtree(partial, ignore_errors=True)
        if isinstance(err, zipfile.BadZipFile):
            raise DescriptionError(f"{path}: the archive is damaged ({err})") from None
        if isinstance(err, OSError) and not isinstance(err, DescriptionError):
            raise DescriptionError(f"{path}: cannot unpack into {into}: {err.strerror or err}") from None
        raise
    return folder


def _checked_members(path: Path, z: zipfile.ZipFile) -> list[zipfile.ZipInfo]:
    """The archive's members, each a plain file or folder whose name stays inside the package; the declared sizes
    within the limits."""
    import stat

    members = z.infolist()
    if len(members) > MAX_MEMBERS:
        raise DescriptionError(f"{path}: the archive has {len(members)} members, more than the {MAX_MEMBERS} a package may have")
    total, seen = 0, set()
    for info in members:
        name = info.filename
        if name.rstrip("/") in seen:
            raise DescriptionError(f"{path}: archive member {name!r} appears twice")
        seen.add(name.rstrip("/"))
        mode = info.external_attr >> 16
        kind = stat.S_IFMT(mode)
        if stat.S_ISLNK(mode):
            raise DescriptionError(f"{path}: archive member {name!r} is a symbolic link: a package holds files only")
        if kind and not (stat.S_ISREG(mode) or stat.S_ISDIR(mode)):
            raise DescriptionError(f"{path}: archive member {name!r} is not a regular file: a package holds files only")
        parts = name.replace("\\", "/").split("/")
        if name.startswith(("/", "\\")) or ".." in parts or (parts and ":" in parts[0]) or "\0" in name:
            raise DescriptionError(f"{path}: archive member {name!r} points outside the package")
        total += info.file_size
        if info.file_size > RATIO_FREE and info.file_size > MAX_RATIO * max(info.compress_size, 1):
            raise DescriptionError(f"{path}: archive member {name!r} expands {info.file_size / max(info.compress_size, 1):.0f}-fold "
                                   f"(to {info.file_size / 2**20:.0f} MiB): more than the {MAX_RATIO}-fold a package may (a zip bomb?)")
    if total > MAX_UNPACKED:
        raise DescriptionError(f"{path}: the archive unpacks to {total / 2**20:.1f} MiB, more than the "
                               f"{MAX_UNPACKED // 2**20} MiB a package may")
    return members


def _copy_member(path: Path, z: zipfile.ZipFile, info: zipfile.ZipInfo, target: Path, room: int) -> int:
    """Stream one member to target, never past its declared size, the ratio or the room left; the bytes written."""
    limit = min(info.file_size, room)
    written = 0
    with z.open(info) as src, open(target, "xb") as dst:
        while block := src.read(_BLOCK):
            written += len(block)
            if written > limit:
                if written > room:
                    raise DescriptionError(f"{path}: the archive unpacks to more than the {MAX_UNPACKED // 2**20} MiB a package may")
                raise DescriptionError(f"{path}: archive member {info.filename!r} holds more than the {info.file_size} bytes it declares")
            dst.write(block)
    return written


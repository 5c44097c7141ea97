"""FMUs unpacked once per machine: a folder per FMU named by its SHA-256, shared by every process that loads it.

Unpacking costs a worker's first run more than its simulation (an FMU has dozens of files to create); a campaign's
workers, and every `tiltload run`, load the same few FMUs. So the first process unpacks an FMU into
$TILTLOAD_CACHE/fmus/<its SHA-256> (default ~/.cache/tiltload, beside the compiled kernels): into a folder of its
own, published by an atomic rename, so that concurrent unpackers never see each other's half-written files, and one
of them wins.

A cached copy is checked each time a process loads it: the same files as the archive, each of the size and CRC-32
the archive's directory declares. One that differs (damaged, edited, a file added or missing, an FMU that wrote into
its own resources) is moved aside and unpacked again. This catches accidents, not a forger: like the kernels beside
it, the cache belongs to its user.

One process loads a cached copy's library once at a time: a second instance of the same FMU alive in the same process
gets a private copy (extraction.py), so that no two instances share a library's globals (dlopen of one path returns
one handle) -- as when every instance had a copy of its own.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import threading
import zipfile
import zlib
from pathlib import Path

COMPLETE = ".complete"  # written last into the unpacked folder, before the rename publishes it
_HELD: dict[str, int] = {}  # digest -> live instances of this process loaded from its cached copy
_LOCK = threading.Lock()


def cache_root() -> Path:
    root = os.environ.get("TILTLOAD_CACHE") or Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "tiltload"
    return Path(root) / "fmus"


def digest(fmu: Path | str) -> str:
    with open(fmu, "rb") as f:
        return hashlib.file_digest(f, "sha256").hexdigest()


class Cached:
    """An instance's hold on a cached copy (`folder`); release() lets the next instance of this process use it."""

    def __init__(self, folder: Path, key: str) -> None:
        self.folder, self._key = str(folder), key

    def release(self) -> None:
        with _LOCK:
            if self._key is not None and _HELD.get(self._key):
                _HELD[self._key] -= 1
            self._key = None


def unpacked(fmu: Path | str):
    """The FMU's unpacked copy for one instance: the cached one (Cached), or a private one (extraction.Unpacked) when
    this process holds the cached one already or the cache cannot be written."""
    from .extraction import Unpacked

    try:
        key = digest(fmu)
    except OSError:
        return Unpacked(fmu)  # FMPy says what is wrong with the file
    with _LOCK:
        if _HELD.get(key):
            return Unpacked(fmu)
        _HELD[key] = 1
    try:
        return Cached(cached_copy(Path(fmu), key), key)
    except (OSError, zipfile.BadZipFile):
        with _LOCK:
            _HELD[key] -= 1
        return Unpacked(fmu)


def cached_copy(fmu: Path, key: str, root: Path | None = None) -> Path:
    """The folder holding the FMU (whose SHA-256 is key) unpacked and checked: unpacked now if missing or not the
    archive's files."""
    root = root or cache_root()
    folder = root / key
    with zipfile.ZipFile(fmu) as z:
        members = {i.filename.rstrip("/"): i for i in z.infolist()}
        if (folder / COMPLETE).is_file() and _matches(folder, members):
            return folder
        if folder.exists():  # not the archive's files: aside (atomically: another process may be reading it), then gone
            aside = folder.with_name(f"{key}.{os.getpid()}.{threading.get_ident()}.stale")
            try:
                folder.rename(aside)
            except OSError:
                pass  # another process moved it first
            shutil.rmtree(aside, ignore_errors=True)
        root.mkdir(parents=True, exist_ok=True, mode=0o700)
        partial = folder.with_name(f"{key}.{os.getpid()}.{threading.get_ident()}.partial")
        shutil.rmtree(partial, ignore_errors=True)
        try:
            from fmpy import extract

            extract(str(fmu), unzipdir=str(partial))
            (partial / COMPLETE).write_text(key)
            try:
                partial.rename(folder)  # atomic: others find nothing or the whole copy
            except OSError:  # another process published it meanwhile
                if not ((folder / COMPLETE).is_file() and _matches(folder, members)):
                    raise
        finally:
            shutil.rmtree(partial, ignore_errors=True)
    return folder


def _matches(folder: Path, members: dict[str, zipfile.ZipInfo]) -> bool:
    """The folder holds exactly the archive's files (and the mark), each of its declared size and CRC-32."""
    found = set()
    for dirpath, dirnames, filenames in os.walk(folder):
        rel = os.path.relpath(dirpath, folder)
        for name in (*dirnames, *filenames):
            found.add(name if rel == "." else f"{rel}/{name}".replace(os.sep, "/"))
    expected = set(members)
    for name in members:  # an archive need not list the folders its files are in
        parts = name.split("/")
        expected.update("/".join(parts[:k]) for k in range(1, len(parts)))
    if found - {COMPLETE} != expected:
        return False
    for name, info in members.items():
        if info.is_dir():
            continue
        path = folder / name
        try:
            if path.is_symlink() or path.stat().st_size != info.file_size or _crc32(path) != info.CRC:
                return False
        except OSError:
            return False
    return True


def _crc32(path: Path) -> int:
    crc = 0
    with open(path, "rb") as f:
        while block := f.read(1 << 20):
            crc = zlib.crc32(block, crc)
    return crc

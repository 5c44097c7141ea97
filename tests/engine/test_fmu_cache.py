"""The machine's unpacked FMUs (engine/fmi/fmu_cache.py): one folder per SHA-256, safe for concurrent unpackers, checked
against the archive at each load, and never one library shared by two live instances of a process."""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
import threading
import time
import zipfile
from pathlib import Path

import pytest
from tiltload.master.engine.fmi import fmu_cache


def _archive_files(fmu: Path) -> dict[str, bytes]:
    with zipfile.ZipFile(fmu) as z:
        return {i.filename: z.read(i) for i in z.infolist() if not i.is_dir()}


def _folder_files(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in folder.rglob("*")
            if p.is_file() and p.name != fmu_cache.COMPLETE}


@pytest.fixture
def fmu(fmus) -> Path:
    return fmus / "TiltloadSensors.fmu"


def test_the_copy_is_named_by_the_archive_s_sha256_and_holds_its_files(fmu, tmp_path):
    key = hashlib.sha256(fmu.read_bytes()).hexdigest()
    folder = fmu_cache.cached_copy(fmu, fmu_cache.digest(fmu), tmp_path)
    assert folder == tmp_path / key
    assert _folder_files(folder) == _archive_files(fmu)
    assert sorted(p.name for p in tmp_path.iterdir()) == [key]  # no partial or stale folder left


@pytest.mark.slow
def test_concurrent_unpackers_publish_one_whole_copy(fmu, tmp_path):
    """Eight threads and three other processes unpack the same FMU into an empty cache at once."""
    key = fmu_cache.digest(fmu)
    go = tmp_path / "go"
    code = ("import os, sys, time, pathlib; from tiltload.master.engine.fmi import fmu_cache as c; go = pathlib.Path(sys.argv[3])\n"
            "(go.parent / f'ready-{os.getpid()}').touch()\n"
            "while not go.exists(): time.sleep(0.001)\n"
            "print(c.cached_copy(pathlib.Path(sys.argv[1]), sys.argv[2], pathlib.Path(sys.argv[4])))")
    procs = [subprocess.Popen([sys.executable, "-c", code, str(fmu), key, str(go), str(tmp_path / "cache")],
                              stdout=subprocess.PIPE, text=True) for _ in range(3)]
    barrier, found = threading.Barrier(8), []

    def unpack():
        barrier.wait()
        found.append(fmu_cache.cached_copy(fmu, key, tmp_path / "cache"))
    threads = [threading.Thread(target=unpack) for _ in range(8)]
    deadline = time.time() + 60
    while len(list(tmp_path.glob("ready-*"))) < 3 and time.time() < deadline:
        time.sleep(0.01)  # the processes are waiting for the go
    go.touch()
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    outputs = [p.communicate(timeout=60)[0].strip() for p in procs]
    assert all(p.returncode == 0 for p in procs)
    assert {str(f) for f in found} | set(outputs) == {str(tmp_path / "cache" / key)}
    assert _folder_files(tmp_path / "cache" / key) == _archive_files(fmu)
    assert os.listdir(tmp_path / "cache") == [key]


@pytest.mark.parametrize("tamper", ["a byte of the library", "a file added", "a file removed", "a file truncated"])
def test_a_damaged_or_edited_copy_is_unpacked_again(fmu, tmp_path, tamper):
    key = fmu_cache.digest(fmu)
    folder = fmu_cache.cached_copy(fmu, key, tmp_path)
    library = next(folder.glob("binaries/*/*.so"))
    if tamper == "a byte of the library":
        data = bytearray(library.read_bytes())
        data[len(data) // 2] ^= 0x01  # the size unchanged: the CRC-32 tells
        library.write_bytes(bytes(data))
    elif tamper == "a file added":
        (folder / "binaries" / "extra.so").write_bytes(b"\x7fELF")
    elif tamper == "a file removed":
        (folder / "modelDescription.xml").unlink()
    else:
        library.write_bytes(library.read_bytes()[:100])
    assert _folder_files(folder) != _archive_files(fmu)
    assert fmu_cache.cached_copy(fmu, key, tmp_path) == folder
    assert _folder_files(folder) == _archive_files(fmu)
    assert os.listdir(tmp_path) == [key]


def _own_copy(fmu: Path, dest: Path) -> Path:
    """The FMU with a note added: another digest, which no instance of this process (earlier tests') holds."""
    with zipfile.ZipFile(fmu) as src, zipfile.ZipFile(dest, "w") as out:
        for item in src.infolist():
            out.writestr(item, src.read(item.filename))
        out.writestr("documentation/note.txt", str(dest))
    return dest


def test_two_live_instances_of_a_process_never_share_the_cached_library(fmu, tmp_path, monkeypatch):
    """The second hold of an FMU while the first is alive is a private copy (dlopen of one path is one handle, one
    set of globals); once released, the cached copy serves the next."""
    monkeypatch.setenv("TILTLOAD_CACHE", str(tmp_path))
    fmu = _own_copy(fmu, tmp_path / "Sensors.fmu")
    first = fmu_cache.unpacked(fmu)
    second = fmu_cache.unpacked(fmu)
    try:
        assert Path(first.folder) == tmp_path / "fmus" / fmu_cache.digest(fmu)
        assert Path(second.folder) != Path(first.folder) and not Path(second.folder).is_relative_to(tmp_path)
        assert _folder_files(Path(second.folder)) == _archive_files(fmu)
    finally:
        second.release()
        first.release()
    assert not Path(second.folder).exists()  # the private copy goes with its instance; the cached one stays
    third = fmu_cache.unpacked(fmu)
    third.release()
    assert third.folder == first.folder and Path(first.folder).is_dir()


def test_an_unwritable_cache_falls_back_to_a_private_copy(fmu, tmp_path, monkeypatch):
    blocked = tmp_path / "file"
    blocked.write_text("")  # a file where the cache's folder would be
    monkeypatch.setenv("TILTLOAD_CACHE", str(blocked))
    held = fmu_cache.unpacked(fmu)
    try:
        assert _folder_files(Path(held.folder)) == _archive_files(fmu)
        assert not Path(held.folder).is_relative_to(blocked)
    finally:
        held.release()

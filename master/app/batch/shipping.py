"""The FMUs of a campaign or a falsification shipped to the workers of an existing Dask cluster, which need no copy of
the FMU folder: the client registers a worker plugin holding the files' bytes (ShippedFmus); the scheduler keeps it and
runs it on every worker there is and every worker that joins later, even after all the others are gone (data scattered
to the workers would be lost with them). Each worker writes the files, checked against their SHA-256, into its
machine's cache, <cache>/shipped/<the set's digest>/ (the first worker of a machine writes, the others find them
there); the engine then unpacks each FMU once per machine into the same cache (engine/fmi/fmu_cache.py), as for a local
run. The tasks run with that folder as their FMU folder. The plugin stays registered under the set's digest (shipping
the same set again replaces it): a cluster that outlives many builds holds a plugin, about a megabyte, a set.

A controller FMU of the user's (a campaign's controllers, a search's controller naming a file) goes with the set, under
controllers/<its digest>/<its file name>: a task's case naming it at the client's path is run with the worker's copy
(the same file name, so its rows name it as the local run's do).
"""

from __future__ import annotations

import hashlib
import json
import os
import threading
from dataclasses import dataclass
from pathlib import Path

from distributed import WorkerPlugin

_READY: dict[str, str] = {}  # set key -> the local folder this process checked (a lookup a task after the first)
_LOCK = threading.Lock()


@dataclass(frozen=True)
class FmuSet:
    """The FMU files a run needs, each (its name in the set's folder, SHA-256 of its bytes); the user's controllers,
    each (its path on the client, its name in the set's folder)."""

    files: tuple[tuple[str, str], ...]
    controllers: tuple[tuple[str, str], ...] = ()

    @property
    def key(self) -> str:
        return hashlib.sha256(json.dumps([self.files, self.controllers]).encode()).hexdigest()[:32]

    def localized(self, case: dict, folder: str) -> dict:
        """The case with its controller at this machine's copy when it names a shipped one (else the case itself)."""
        name = dict(self.controllers).get(case.get("controller"))
        return case if name is None else {**case, "controller": str(Path(folder) / name)}


def fmu_set(folder: Path, names: list[str], controllers: list[str] = ()) -> tuple[FmuSet, dict[str, bytes]]:
    """The set of these files of the folder and of the user's controller FMUs (their paths here), and their bytes
    (what the client sends)."""
    data = {name: (Path(folder) / name).read_bytes() for name in names}
    moved = []
    for path in sorted(set(controllers)):
        blob = Path(path).read_bytes()
        name = f"controllers/{hashlib.sha256(blob).hexdigest()[:16]}/{Path(path).name}"
        data[name] = blob
        moved.append((path, name))
    return FmuSet(tuple((name, hashlib.sha256(b).hexdigest()) for name, b in data.items()), tuple(moved)), data


def shipped_folder(fmus: FmuSet) -> Path:
    from ....native_fmu.cache import cache_root

    return cache_root() / "shipped" / fmus.key


def install(fmus: FmuSet, data: dict[str, bytes]) -> str:
    """This machine's folder holding the set, written now where a file is missing or not its digest."""
    with _LOCK:
        folder = shipped_folder(fmus)
        folder.mkdir(parents=True, exist_ok=True, mode=0o700)
        for name, digest in fmus.files:
            target = folder / name
            if target.is_file() and _digest(target) == digest:
                continue
            blob = data[name]
            if hashlib.sha256(blob).hexdigest() != digest:  # the bytes are the client's: this would be a bug
                raise RuntimeError(f"the shipped {name} is not the file the client sent (SHA-256 differs)")
            target.parent.mkdir(parents=True, exist_ok=True, mode=0o700)
            part = target.with_name(f".{target.name}.{os.getpid()}.{threading.get_ident()}.part")
            part.write_bytes(blob)
            os.replace(part, target)  # atomic: another worker of this machine finds the whole file or none
        _READY[fmus.key] = str(folder)
        return _READY[fmus.key]


def local_folder(fmus: FmuSet) -> str:
    """This machine's folder holding the set, checked once per process (MissingFmu: the plugin did not write it)."""
    from .worker import MissingFmu

    with _LOCK:
        if fmus.key in _READY:
            return _READY[fmus.key]
        folder = shipped_folder(fmus)
        for name, digest in fmus.files:
            if not (folder / name).is_file() or _digest(folder / name) != digest:
                raise MissingFmu(f"the shipped {name} is not in {folder} (its worker plugin did not write it: see the "
                                 "worker's log)")
        _READY[fmus.key] = str(folder)
        return _READY[fmus.key]


def _digest(path: Path) -> str:
    with open(path, "rb") as f:
        return hashlib.file_digest(f, "sha256").hexdigest()


class ShippedFmus(WorkerPlugin):
    """The Dask worker plugin that writes the set into its worker's machine cache as the worker joins (setup)."""

    def __init__(self, fmus: FmuSet, data: dict[str, bytes]) -> None:
        self.fmus, self.data = fmus, data

    def setup(self, worker) -> None:
        install(self.fmus, self.data)

    def teardown(self, worker) -> None:
        pass


class WithShippedFmus:
    """A campaign's or a falsification's task run on a worker with its machine's copy of the shipped FMUs as fmu_dir
    (the keyword the task takes)."""

    def __init__(self, task, fmus: FmuSet) -> None:
        self.task, self.fmus = task, fmus

    def __call__(self, case: dict, **shared) -> dict:
        from .worker import MissingFmu, environment_failure

        try:
            folder = local_folder(self.fmus)
        except MissingFmu as err:  # its environment's failure, as a file the worker cannot see: tried elsewhere
            return environment_failure(err)
        return self.task(self.fmus.localized(case, folder), fmu_dir=folder, **shared)


def ship(client, folder: Path, names: list[str], controllers: list[str] = ()) -> FmuSet:
    """Register the set's plugin on the client's cluster (its workers now, and later ones): the set. controllers: the
    user's controller FMUs the runs name (paths on this machine)."""
    fmus, data = fmu_set(folder, names, controllers)
    client.register_plugin(ShippedFmus(fmus, data), name=f"tiltload-fmus-{fmus.key}")
    return fmus


def prepare_shipped(fmus: FmuSet, base, case: dict) -> bool:
    """The Dask task that prepares a worker (campaign/worker.prepare) with its copy of the shipped FMUs."""
    from .worker import prepare

    try:
        folder = local_folder(fmus)
    except OSError:
        return False
    return prepare(base, fmus.localized(case, folder), folder)

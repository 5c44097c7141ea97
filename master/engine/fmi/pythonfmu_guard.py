"""Keep pythonfmu's Python state alive for the whole process.

pythonfmu 0.7's wrapper tears its interpreter state down when the first library copy that
instantiated an FMU is unloaded; any later instantiation in the same process then crashes
(PythonFMU #213, #228). FMPy's simulate_fmu() unloads the library after every run, so a
second run in one Python process would crash. pin() instantiates the FMU once from a private
copy and never unloads it; call it before anything else loads a pythonfmu FMU.

Native FMUs (all of tiltload's) need no pin: pin() leaves them alone; only a controller made
by `tiltload wrap` (or another pythonfmu FMU) is pinned. Every distinct pythonfmu FMU (model
identifier) needs its own pin: a second FMU loaded and unloaded after the first one was pinned
still crashes on its next load.

The pinned libraries can also crash when the interpreter shuts down ("corrupted double-linked
list", exit 134: seen once in three full test runs that had loaded four pythonfmu FMUs). So a
process that pinned one ends with exit_now(): it removes the extracted copies, flushes its
output and leaves without running the shutdown that crashes. Nothing of ours is lost there:
logs are closed before the commands return.
"""

from __future__ import annotations

import atexit
import os
import sys
from pathlib import Path

_PINNED: dict[str, object] = {}
_FOLDERS: list = []  # the pinned copies (extraction.Unpacked)


def pin(fmu: Path | str) -> None:
    """Instantiate one pythonfmu FMU once and keep its library loaded until the process exits."""
    import zipfile

    from fmpy import read_model_description
    from fmpy.fmi2 import FMU2Slave

    from .extraction import Unpacked

    with zipfile.ZipFile(fmu) as z:
        if "resources/slavemodule.txt" not in z.namelist():
            return  # not a pythonfmu FMU: nothing to keep alive
    md = read_model_description(str(fmu))
    if md.coSimulation.modelIdentifier in _PINNED:
        return
    unpacked = Unpacked(fmu)  # removed at exit, or by its reaper if the process dies (a pythonfmu FMU that crashes)
    unzipdir = unpacked.folder
    slave = FMU2Slave(
        guid=md.guid, unzipDirectory=unzipdir, modelIdentifier=md.coSimulation.modelIdentifier,
        instanceName="tiltload_pin",
    )
    slave.instantiate()
    slave.fmi2FreeInstance(slave.component)  # the instance goes, the library stays
    _PINNED[md.coSimulation.modelIdentifier] = slave
    _FOLDERS.append(unpacked)
    atexit.register(unpacked.release)


def pinned() -> bool:
    return bool(_PINNED)


def exit_now(code: int) -> None:
    """End the process with code, skipping the interpreter shutdown that pinned pythonfmu libraries can crash."""
    for unpacked in _FOLDERS:
        unpacked.release()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except Exception:
            pass
    os._exit(code)

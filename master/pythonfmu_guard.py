"""Keep pythonfmu's Python state alive for the whole process.

pythonfmu 0.7's wrapper tears its interpreter state down when the first library copy that
instantiated an FMU is unloaded; any later instantiation in the same process then crashes
(PythonFMU #213, #228). FMPy's simulate_fmu() unloads the library after every run, so a
second run in one Python process would crash. pin() instantiates the FMU once from a private
copy and never unloads it; call it before anything else loads a pythonfmu FMU.

Native FMUs (ours are, but for the controller) need no pin: pin() leaves them alone.
Every distinct pythonfmu FMU (model identifier) needs its own pin: a second FMU loaded and
unloaded after the first one was pinned still crashes on its next load.
"""

from __future__ import annotations

import atexit
import shutil
from pathlib import Path

_PINNED: dict[str, object] = {}


def pin(fmu: Path | str) -> None:
    """Instantiate one pythonfmu FMU once and keep its library loaded until the process exits."""
    import zipfile

    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    with zipfile.ZipFile(fmu) as z:
        if "resources/slavemodule.txt" not in z.namelist():
            return  # not a pythonfmu FMU: nothing to keep alive
    md = read_model_description(str(fmu))
    if md.coSimulation.modelIdentifier in _PINNED:
        return
    unzipdir = extract(str(fmu))
    slave = FMU2Slave(
        guid=md.guid, unzipDirectory=unzipdir, modelIdentifier=md.coSimulation.modelIdentifier,
        instanceName="tiltload_pin",
    )
    slave.instantiate()
    slave.fmi2FreeInstance(slave.component)  # the instance goes, the library stays
    _PINNED[md.coSimulation.modelIdentifier] = slave
    atexit.register(shutil.rmtree, unzipdir, True)

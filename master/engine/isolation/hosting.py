"""Where one instance's FMU runs: on a `tiltload serve` (its description names one), in a worker process of its
own (the isolation policy says so), or in this process.

`slave_for` is what the execution calls to create each instance's slave; the three kinds are the
same Slave to everything after it.
"""

from __future__ import annotations

from pathlib import Path

from ..errors import ExecutionError
from ..fmi.in_process import load
from ..fmi.model_description import is_scheduled
from ..fmi.slave import Slave
from . import handshake
from .process import STEP_TIMEOUT, IsolatedFmu
from .remote_client import RemoteHost

SHARED_MEMORY = True  # a local worker's steps go over shared memory where they can (link.py)


def remote_fmu(name: str, path, md, address: str, token_file, timeout: float = STEP_TIMEOUT,
               tick: float | None = None) -> IsolatedFmu:
    """The FMU of model description md served by `tiltload serve` at address (picked there by model identifier and
    GUID), authenticated with the secret in token_file; every call watched for timeout seconds. tick: the execution's
    (an FMI 3.0 FMU's clocks are placed on it there)."""
    if token_file is None:
        raise ExecutionError(f"{name}: runs on tiltload serve at {address}, which needs the shared secret (--token-file)")
    return IsolatedFmu(name, path, md, timeout, host=RemoteHost(address, handshake.read_token(token_file), name, md, tick))


def slave_for(spec, md, isolate=None, step_timeout: float | None = None, tick: float | None = None) -> Slave:
    """The slave of instance spec (system.Instance) with model description md: remote if spec.remote names a server,
    isolated if isolate(fmu, md) says so (None: never), else in this process; FMI 2.0 or 3.0 alike, an FMU with
    clocks stepped on the system's tick wherever it runs (a Scheduled Execution FMU not on a server)."""
    timeout = step_timeout or STEP_TIMEOUT
    if is_scheduled(md) and spec.remote is not None:
        raise ExecutionError(f"{spec.name}: {Path(spec.fmu).name} is a Scheduled Execution FMU, which runs in this process "
                             "or a worker process of its own, not on a tiltload serve (--remote hosts co-simulation FMUs)")
    if spec.remote is not None:
        return remote_fmu(spec.name, spec.fmu, md, spec.remote, spec.token_file, timeout, tick)
    if isolate is not None and isolate(spec.fmu, md):
        return IsolatedFmu(spec.name, spec.fmu, md, timeout, tick=tick, shared_memory=SHARED_MEMORY)
    return load(spec.name, spec.fmu, md, tick)

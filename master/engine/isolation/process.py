"""The master's side of an FMU hosted in its own process (worker.py), with a watchdog.

`IsolatedFmu` is a Slave like the in-process FMU: output tables, raw setters, do_step,
read_outputs, initialize, reset, close. Inputs set before a step are queued and travel with
it, so one step is one round trip: set + doStep + get, in raw bytes (wire.py). Every reply must
come within `timeout` seconds; a worker that dies (signal, exit()) or stays silent becomes one
ExecutionError naming the instance, the call and what happened, and the worker is killed.

Which FMUs run this way is the caller's policy (Execution's `isolate`): the tiltload application
isolates every FMU it did not compile itself, unless the user trusts it (`--trust-fmus`).
"""

from __future__ import annotations

import ctypes
import os
import select
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from .. import slave
from ..errors import DescriptionError, ExecutionError
from . import wire

STEP_TIMEOUT = 10.0  # s a call may take before the watchdog kills the FMU's process (--step-timeout)
START_TIMEOUT = 60.0  # s for the process to start and instantiate (a pythonfmu FMU starts an interpreter)
WORKER_MODULE = "tiltload.master.engine.isolation.worker"


def _signal_name(number: int) -> str:
    try:
        return signal.Signals(number).name
    except ValueError:
        return f"signal {number}"


class IsolatedFmu(slave.Slave):
    """One FMU instance in a worker process."""

    def __init__(self, name: str, path: Path, md, timeout: float = STEP_TIMEOUT) -> None:
        super().__init__(name, path, md)
        self.timeout = float(timeout)
        self.values = {t: np.zeros(len(vs), dtype=np.dtype(slave.C_TYPES[t])) for t, vs in self.outputs.items()}
        self.setters = {t: self._queue(t) for t in slave.TYPES}
        self._pending: list = []
        self._dead = False
        self._stderr = tempfile.TemporaryFile()
        req_r, self._req = os.pipe()
        self._rep, rep_w = os.pipe()
        try:
            self.proc = subprocess.Popen(
                [sys.executable, "-m", WORKER_MODULE, str(self.path), name, str(req_r), str(rep_w)],
                pass_fds=(req_r, rep_w), stdin=subprocess.DEVNULL, stdout=self._stderr, stderr=self._stderr)
        finally:
            os.close(req_r)
            os.close(rep_w)
        self._exchange(None, "instantiate", max(self.timeout, START_TIMEOUT))

    def _queue(self, typ: str):
        width = ctypes.sizeof(slave.C_TYPES[typ])

        def setter(component, vrs, n, buf):  # the raw bytes the step message carries, copied once
            self._pending.append((typ, n, ctypes.string_at(vrs, 4 * n), ctypes.string_at(buf, width * n)))
            return 0
        return setter

    def _last_stderr(self) -> str:
        self._stderr.seek(0)
        lines = [ln.strip() for ln in self._stderr.read().decode(errors="replace").splitlines() if ln.strip()]
        return lines[-1] if lines else ""

    def _gone(self, what: str) -> ExecutionError:
        """The worker closed its pipe: say how it ended."""
        self._dead = self.fatal = True
        try:
            code = self.proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            code = self.proc.wait()
        how = (f"the FMU crashed ({_signal_name(-code)})" if code < 0 else
               f"the FMU ended its process with exit({code})")
        said = self._last_stderr()
        return ExecutionError(f"{self.name}: {how} in {what}" + (f"; it said: {said}" if said else ""))

    def _exchange(self, request, what: str, timeout: float | None = None):
        """Send request (a tuple to pickle, raw step bytes, or None: only wait for the worker's greeting);
        the reply's outputs land in self.values."""
        if self._dead:
            raise ExecutionError(f"{self.name}: {what}: the FMU's process has already ended")
        timeout = self.timeout if timeout is None else timeout
        started = time.perf_counter()
        try:
            if isinstance(request, bytes):
                wire.send_bytes(self._req, request)
            elif request is not None:
                wire.send(self._req, request)
            deadline = started + timeout
            header = b""
            while len(header) < wire.HEADER.size:
                left = deadline - time.perf_counter()
                if left <= 0 or not select.select([self._rep], [], [], left)[0]:
                    self._dead = self.fatal = True
                    self.proc.kill()
                    self.proc.wait()
                    raise ExecutionError(f"{self.name}: {what} did not return within {timeout:g} s (watchdog; "
                                         f"--step-timeout sets the limit): its process was killed")
                chunk = os.read(self._rep, wire.HEADER.size - len(header))
                if not chunk:
                    raise self._gone(what)
                header += chunk
            body = wire.receive_exact(self._rep, wire.HEADER.unpack(header)[0])
        except BrokenPipeError:
            raise self._gone(what) from None
        finally:
            self.fmi_seconds += time.perf_counter() - started
        if body is None:
            raise self._gone(what)
        if body[:1] == wire.OUTPUTS:  # a step's raw reply
            self.log.extend(wire.decode_outputs(body, self.values))
            return None
        reply = wire.unpickle(body)
        if reply[0] == "ok":
            _, outputs, log = reply
            self.log.extend(log)
            if isinstance(outputs, bytes):  # a serialized state
                return outputs
            if outputs is not None:
                for t, v in outputs.items():
                    self.values[t][:] = v
            return outputs
        _, kind, message, fatal, log = reply
        self.log.extend(log)
        self.fatal = fatal
        raise (DescriptionError if kind == "description" else ExecutionError)(message)

    def initialize(self, parameters: dict) -> None:
        self._pending.clear()
        self._exchange(("init", dict(parameters)), "initialization")

    def reset(self) -> None:
        self._pending.clear()
        self._exchange(("reset",), "reset")

    def set_values(self, values: dict) -> None:
        self._exchange(("set", dict(values)), "setting values")

    def get_state(self) -> bytes:
        return self._exchange(("get_state",), "getting its state")

    def set_state(self, state: bytes) -> None:
        self._pending.clear()
        self._exchange(("set_state", state), "restoring its state")

    def do_step(self, t: float, h: float) -> None:
        sets, self._pending = self._pending, []
        self._exchange(wire.encode_step(sets, t, h), f"doStep at t={t:.6g} s")

    def read_outputs(self) -> None:
        """Nothing to ask: the outputs came with the last step or the initialization."""

    def close(self) -> None:
        """Ask the worker to terminate and free the FMU; kill it if it does not within the watchdog."""
        try:
            if not self._dead:
                try:
                    self._exchange(("close",), "terminate", timeout=min(self.timeout, 5.0))
                except (ExecutionError, DescriptionError):
                    pass
            if self.proc.poll() is None:
                try:
                    self.proc.wait(timeout=5)
                except subprocess.TimeoutExpired:
                    self.proc.kill()
                    self.proc.wait()
        finally:
            for fd in (self._req, self._rep):
                try:
                    os.close(fd)
                except OSError:
                    pass
            self._stderr.close()
            self._dead = True

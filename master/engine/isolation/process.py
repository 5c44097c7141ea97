"""The master's side of an FMU hosted elsewhere (a worker process here, or `tiltload serve` on another machine),
with a watchdog.

`IsolatedFmu` is a Slave like the in-process FMU: output tables, raw setters, do_step,
read_outputs, initialize, reset, close. Inputs set before a step are queued and travel with
it, so one step is one round trip: set + doStep + get, in raw bytes (wire.py). Every reply must
come within `timeout` seconds; a host that dies (signal, exit(), a lost connection) or stays
silent becomes one ExecutionError naming the instance, the call and what happened.

Where the FMU runs is the host's business: `WorkerProcess` (below: a worker on a pipe pair) or
`remote_client.RemoteHost` (a TCP connection to `tiltload serve`). Both give a transport.Channel,
say how they ended, and can be cut off when the watchdog fires; the exchange, the watchdog and
the error lines here are the same for both.

Which FMUs run this way is the caller's policy (Execution's `isolate`): the tiltload application
isolates every FMU it did not compile itself, unless the user trusts it (`--trust-fmus`).
"""

from __future__ import annotations

import ctypes
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from ..errors import DescriptionError, ExecutionError, FmuEndedRun
from ..fmi import slave
from ..fmi.model_description import clocks_of, fmi_type, fmi_version, is_scheduled
from . import link, wire
from .transport import Channel, FrameTooLarge, LinkClosed, LinkTimeout

STEP_TIMEOUT = 10.0  # s a call may take before the watchdog ends it (--step-timeout)
START_TIMEOUT = 60.0  # s for the host to start and instantiate (a pythonfmu FMU starts an interpreter)
WORKER_MODULE = "tiltload.master.command_line.worker"  # its command line; the hosting itself is worker.py
WORKER_COMMAND = (sys.executable, "-m", WORKER_MODULE)  # what starts a worker (a test puts a misbehaving host here)
# A worker steps its one FMU in lock-step with the master, which waits on the other core: numeric libraries' thread
# pools (numpy's OpenBLAS, MKL, OpenMP) start with one thread there unless the user set them. Measured (2 cores): a
# pythonfmu controller's round trip on the shared-memory link took 6 to 11 µs beyond its FMU's calls with OpenBLAS's
# default pool in the worker, 2.5 to 2.9 µs with one thread.
SINGLE_THREADED = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def worker_environment() -> dict[str, str]:
    """A worker's environment: this process's, with the thread pools above at one thread unless set."""
    return {**{name: "1" for name in SINGLE_THREADED}, **os.environ}


def _signal_name(number: int) -> str:
    try:
        return signal.Signals(number).name
    except ValueError:
        return f"signal {number}"


def how_it_ended(code: int) -> str:
    """A worker's end by its exit status (Popen's returncode: negative for a signal)."""
    return f"the FMU crashed ({_signal_name(-code)})" if code < 0 else f"the FMU ended its process with exit({code})"


class WorkerProcess:
    """The FMU's host on this machine: a worker process (worker.py) on a pipe pair."""

    def __init__(self, path: Path, name: str, tick: float | None = None, segment=None) -> None:
        """segment (link.Segment): shared with the worker, for the steps over shared memory."""
        self._stderr = tempfile.TemporaryFile()
        placed = ["--tick", repr(float(tick))] if tick is not None else []  # an FMI 3.0 FMU's clocks go on the master's tick
        shared = ["--shm", str(segment.fd)] if segment is not None else []
        req_r, req_w = os.pipe()
        rep_r, rep_w = os.pipe()
        try:
            self.proc = subprocess.Popen(
                [*WORKER_COMMAND, str(path), name, "--pipes", str(req_r), str(rep_w), *placed, *shared],
                pass_fds=(req_r, rep_w, *([segment.fd] if segment is not None else [])), stdin=subprocess.DEVNULL,
                stdout=self._stderr, stderr=self._stderr, env=worker_environment())
        except BaseException:
            for fd in (req_w, rep_r):
                os.close(fd)
            raise
        finally:
            os.close(req_r)
            os.close(rep_w)
        self.channel = Channel.over_pipes(rep_r, req_w)

    def _last_stderr(self) -> str:
        self._stderr.seek(0)
        lines = [ln.strip() for ln in self._stderr.read().decode(errors="replace").splitlines() if ln.strip()]
        return lines[-1] if lines else ""

    def ended(self, what: str) -> str:
        """The worker closed its pipe: how it ended, and its last words."""
        try:
            code = self.proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            code = self.proc.wait()
        how = how_it_ended(code)
        said = self._last_stderr()
        return f"{how} in {what}" + (f"; it said: {said}" if said else "")

    def cut_off(self) -> str:
        """The watchdog fired: kill the worker (it may be hung inside the FMU)."""
        self.proc.kill()
        self.proc.wait()
        return "its process was killed"

    def close(self) -> None:
        """After the close request (or none): wait for the worker to exit, kill it if it does not."""
        try:
            if self.proc.poll() is None:
                try:
                    self.proc.wait(timeout=5)
                except subprocess.TimeoutExpired:
                    self.proc.kill()
                    self.proc.wait()
        finally:
            self.channel.close()
            self._stderr.close()


def _link_typed(md) -> bool:
    """Does the shared-memory link carry each of the FMU's inputs and outputs as its own type? The host's C loop gets
    and sets Float64, Int32 and Boolean (and FMI 2.0's Enumerations, as Integers); an FMU with other types (Float32,
    Int8, ..., String, Binary) is stepped on its pipe, where the worker converts them."""
    own = ("Float64", "Int32", "Boolean", *(("Enumeration",) if fmi_version(md) == 2 else ()))
    return all(fmi_type(v) in own for v in md.modelVariables if v.causality in ("input", "output"))


class IsolatedFmu(slave.Slave):
    """One FMU instance hosted outside this process: by a local worker unless another host is given."""

    def __init__(self, name: str, path: Path, md, timeout: float = STEP_TIMEOUT, host=None, tick: float | None = None,
                 shared_memory: bool = False) -> None:
        """host: something with `channel` (transport.Channel), `ended(what)`, `cut_off()` and `close()`,
        already started (remote_client.RemoteHost); None: a worker process on this machine, told tick (the
        execution's, on which an FMI 3.0 FMU's clocks tick). shared_memory: the tick loop steps a local worker's FMU
        over shared memory (link.py) where it can (FMI 2.0 and 3.0 of the link's types, on Linux; with clocks or
        Scheduled Execution too, its host then steps it with the kernel's own sequence)."""
        super().__init__(name, path, md)
        self.timeout = float(timeout)
        self.values = {t: np.zeros(len(vs), dtype=np.dtype(slave.C_TYPES[t])) for t, vs in self.outputs.items()}
        self.setters = {t: self._queue(t) for t in slave.TYPES}
        self._pending: list = []
        self._texts_at_init: dict | None = None  # during initialize: the String and Binary inputs connect() sets
        self.clocks = clocks_of(md)  # a failure its host reports names one by its index (native/failures.py)
        self.clocked = bool(self.clocks)  # stepped in Event Mode by its host: its inputs are not set at initialization
        self.scheduled = is_scheduled(md)  # its partitions activated by its host, and its failures worded so
        self._dead = self._closed = False
        # String and Binary outputs: their values come with every reply of outputs (wire.py), logged as in process
        self.text_outputs = [v for v in md.modelVariables if v.causality == "output" and fmi_type(v) in ("String", "Binary")]
        self._binaries = {v.name for v in self.text_outputs if fmi_type(v) == "Binary"}
        self._reply_limit = wire.reply_limit({t: len(vs) for t, vs in self.outputs.items()}, bool(self.text_outputs))
        self.segment = None
        self.link = None  # kernel.Link while the loop may step it over shared memory
        self.linked = False  # the host is in its C loop on the segment (not on its pipe)
        if shared_memory and host is None and link.available() and _link_typed(md):  # else the pipe
            size, out_offset = link.segment_size(sum(1 for v in md.modelVariables if v.causality == "input"),
                                                 {t: len(vs) for t, vs in self.outputs.items()})
            link.host_library()  # built here, into the cache the worker loads it from (not within a step's watchdog)
            self.segment = link.Segment(name, size, out_offset)
        try:
            self.host = host if host is not None else WorkerProcess(self.path, name, tick, self.segment)
        except BaseException:
            if self.segment is not None:
                self.segment.close()
            raise
        self.channel = self.host.channel
        try:
            self._exchange(None, "instantiate", max(self.timeout, START_TIMEOUT))
        except BaseException:
            self.close()
            raise

    def _queue(self, typ: str):
        width = ctypes.sizeof(slave.C_TYPES[typ])

        def setter(component, vrs, n, buf):  # the raw bytes the step message carries, copied once
            self._pending.append((typ, n, ctypes.string_at(vrs, 4 * n), ctypes.string_at(buf, width * n)))
            return 0
        return setter

    def _fail(self, message: str) -> ExecutionError:
        self._dead = self.fatal = True
        return ExecutionError(f"{self.name}: {message}")

    def _exchange(self, request: bytes | None, what: str, timeout: float | None = None, limit: int | None = None):
        """Send request (wire bytes, or None: only wait for the host's greeting); a reply with outputs lands in
        self.values, a state is returned. limit: the longest reply accepted (the model's outputs and a log)."""
        if self._dead:
            raise ExecutionError(f"{self.name}: {what}: the FMU's host has already ended")
        if self.linked and request is not None:  # its host answers on the pipe again, once it left the segment
            self.unlink(what)
        timeout = self.timeout if timeout is None else timeout
        started = time.perf_counter()
        try:
            if request is not None:
                self.channel.send(request)
            body = self.channel.receive(timeout, self._reply_limit if limit is None else limit)
        except LinkTimeout:
            raise self._fail(f"{what} did not return within {timeout:g} s (watchdog; --step-timeout sets the limit): "
                             f"{self.host.cut_off()}") from None
        except LinkClosed:
            raise self._fail(self.host.ended(what)) from None
        except FrameTooLarge as err:
            raise self._fail(f"{what}: its host sent {err} ({self.host.cut_off()})") from None
        finally:
            self.fmi_seconds += time.perf_counter() - started
        try:
            if body[:1] == wire.OUTPUTS:  # a step's (or the initialization's) raw reply
                texts: dict = {}
                self.log.extend(wire.decode_outputs(body, self.values, texts))
                self._take_texts(texts)
                return None
            if body[:1] == wire.ENDED:  # a step's: the FMU ended the run, its outputs there are valid
                texts = {}
                t, failure, log = wire.decode_ended(body, self.values, texts)
                self.log.extend(log)
                self._take_texts(texts)
                raise FmuEndedRun(self.name, t, ExecutionError(failure))
            if body[:1] == wire.STATE:  # get_state's reply
                state, log = wire.decode_state(body)
                self.log.extend(log)
                return state
            reply = wire.decode_reply(body)
        except wire.ProtocolError as err:
            raise self._fail(f"{what}: its host sent a malformed reply ({err}; {self.host.cut_off()})") from None
        self.log.extend(reply["log"])
        if reply.get("ok") is True:
            return None
        self.fatal = bool(reply.get("fatal"))
        if reply["error"] == "protocol":
            raise self._fail(f"{what}: its host refused the request ({reply['message']})")
        if reply["error"] == "ended":  # the server saw the FMU's process end, and says how
            raise self._fail(f"{reply['message']} in {what}" + (f" on {self.host.where}" if hasattr(self.host, "where") else ""))
        raise (DescriptionError if reply["error"] == "description" else ExecutionError)(reply["message"])

    def _take_texts(self, received: dict) -> None:
        """A reply's String and Binary outputs into texts: only the model's, a Binary's hexadecimal as bytes."""
        names = {v.name for v in self.text_outputs}
        for name, value in received.items():
            if name not in names:
                raise wire.ProtocolError(f"a value for {name[:40]!r}, not a String or Binary output of this model")
            try:
                self.texts[name] = bytes.fromhex(value) if name in self._binaries else value
            except ValueError:
                raise wire.ProtocolError(f"Binary output {name} not in hexadecimal") from None

    def read_texts(self) -> None:
        """Nothing to ask: the String and Binary outputs came with the last step or the initialization."""

    # ---- the shared-memory link (link.py) ------------------------------------------------------------------------
    def link_for(self, groups: list[tuple[str, np.ndarray]]) -> object | None:
        """The kernel.Link the tick loop steps this FMU through, its host told where the groups' values (type, value
        references, in the loop's order) go; None if this FMU has no segment. The host is in its C loop after it."""
        if self.segment is None or self._dead:
            return None
        from ..native import kernel

        if self.link is None or self._link_groups != groups:
            offsets = link.plan_link([(t, len(vrs)) for t, vrs in groups], self.segment.out_offset)
            self._offsets = (ctypes.c_int64 * max(len(offsets), 1))(*offsets)
            self._link_groups = groups
            seq = self.link.seq if self.link is not None else 0
            self.link = kernel.Link(base=self.segment.address, size=self.segment.size,
                                    in_offset=ctypes.addressof(self._offsets), out_offset=self.segment.out_offset,
                                    seq=seq, hung_up_fd=self.channel.read_fd, signal_fd=-1, timeout_ns=int(self.timeout * 1e9),
                                    spin_ns=link.SPIN_NS, n_clocks=len(self.clocks))
        if not self.linked:
            self._pending.clear()
            self._exchange(wire.control({"op": "link", "groups": [[t, [int(v) for v in vrs]] for t, vrs in groups],
                                         "in_offset": list(self._offsets)[:len(groups)],
                                         "out_offset": self.segment.out_offset, "seq": int(self.link.seq)}),
                           "taking the shared-memory link", max(self.timeout, START_TIMEOUT))
            self.linked = True
        return self.link

    def unlink(self, what: str) -> None:
        """The host back on its pipe (before a request there): a yield over the segment, answered on the pipe with the
        FMU's log lines since."""
        from ..native import kernel

        self.linked = False
        kernel.library().tl_link_yield(ctypes.byref(self.link))
        self._exchange(None, what)

    def abandon_link(self) -> None:
        """A step over the link left unanswered (a signal stopped the wait): its host, maybe hung in it, is killed."""
        if not self._dead:
            self._dead = self.fatal = True
            self.linked = False
            self.host.cut_off()

    def link_failed(self, failure: int, corruption: int, t: float) -> ExecutionError:
        """The error line of a step over the link that failed (tl_codes.h's TL_LINK_FAILURES)."""
        from ..native.codes import LinkCorruption, LinkFailure

        what = f"doStep at t={t:.6g} s"
        self.linked = False
        if failure == LinkFailure.INTERRUPTED:  # a signal whose handler did not raise: the step is lost all the same
            return ExecutionError(f"{self.name}: {what}: the wait for its answer was interrupted by a signal")
        if failure == LinkFailure.TIMEOUT:
            return self._fail(f"{what} did not return within {self.timeout:g} s (watchdog; --step-timeout sets the limit): "
                              f"{self.host.cut_off()}")
        if failure == LinkFailure.ENDED:
            return self._fail(self.host.ended(what))
        reason = {LinkCorruption.SEQUENCE: "a sequence number it was not asked for",
                  LinkCorruption.LENGTH: "outputs of another length than the model's",
                  LinkCorruption.CALL: "an unknown call or status",
                  LinkCorruption.TIME: "a time outside the step"}.get(corruption, "garbage")
        return self._fail(f"{what}: its host sent a corrupt reply on shared memory ({reason}; {self.host.cut_off()})")

    def failed(self, what: str, status: int) -> ExecutionError:
        if self.linked and not self._dead:  # the FMU's last words are in its host: fetched with the yield
            try:
                self.unlink(what)
            except (ExecutionError, DescriptionError):
                pass
        return super().failed(what, status)

    @property
    def connects_in_initialization(self) -> bool:
        """The master may set its connected inputs at initialization (initialize's connect): they travel with the init
        request, set by the host in Initialization Mode as in this process. Not with clocks (Event Mode only)."""
        return not self.clocked

    def initialize(self, parameters: dict, connect=None, start: float = 0.0) -> None:
        """connect(): the master's setters queue the connected inputs at t = 0, sent with the request. start: the
        system's start time (sent when it is not 0)."""
        self._pending.clear()
        self._texts_at_init = {}  # the String and Binary inputs connect() sets: with the request too
        try:
            if connect is not None:
                connect()
        finally:
            texts, self._texts_at_init = self._texts_at_init, None
        sets, self._pending = self._pending, []
        request = {"op": "init", "parameters": dict(parameters), **({"inputs": wire.encode_inputs(sets)} if sets else {}),
                   **({"texts": texts} if texts else {}), **({"start": float(start)} if start else {})}
        self._exchange(wire.control(request), "initialization")

    def reset(self) -> None:
        self._pending.clear()
        self._exchange(wire.control({"op": "reset"}), "reset")

    def set_values(self, values: dict) -> None:
        if self._texts_at_init is not None:  # inputs connected at initialization: set in its Initialization Mode
            self._texts_at_init.update(values)
            return
        self._exchange(wire.control({"op": "set", "values": dict(values)}), "setting values")

    def get_state(self) -> bytes:
        return self._exchange(wire.control({"op": "get_state"}), "getting its state", limit=wire.STATE_FRAME_LIMIT)

    def set_state(self, state: bytes) -> None:
        self._pending.clear()
        try:
            request = wire.encode_state(state)
        except wire.ProtocolError as err:
            raise ExecutionError(f"{self.name}: restoring its state: {err}") from None
        self._exchange(request, "restoring its state")

    def do_step(self, t: float, h: float) -> None:
        sets, self._pending = self._pending, []
        self._exchange(wire.encode_step(sets, t, h), f"doStep at t={t:.6g} s")

    def read_outputs(self) -> None:
        """Nothing to ask: the outputs came with the last step or the initialization."""

    def close(self) -> None:
        """Ask the host to terminate and free the FMU (within the watchdog, at most 5 s), then let it go."""
        if self._closed:
            return
        self._closed = True
        try:
            if not self._dead:
                try:
                    self._exchange(wire.control({"op": "close"}), "terminate", timeout=min(self.timeout, 5.0))
                except (ExecutionError, DescriptionError):
                    pass
        finally:
            self._dead = True
            self.host.close()
            if self.segment is not None:
                self.segment.close()

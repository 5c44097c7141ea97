"""A process that hosts one FMU for the master (`python -m tiltload.master.fmu_worker`).

An FMU that is not ours can crash (segfault), call exit() or hang. In its own process that
costs the process, not the run: the master sees the pipe close or its watchdog expire and says
so in one line, with the log it has written so far intact. See fmu_process.py for the master's side.

Protocol: length-prefixed messages on two pipes the master passes by number. The step, the hot
path, is raw bytes (encode_step / encode_outputs: no pickling per tick); the rest is pickled,
after a b"P". Requests:
  step                          apply sets [(type, vrs, values)], doStep(t, h); reply: the outputs
  P ("init", parameters)        initialization; reply: the outputs at t = 0
  P ("reset",)                  fmi2Reset
  P ("close",)                  terminate, free, exit
Replies: the outputs as raw bytes (plus new log lines, pickled, when there are any), or
         P ("ok", outputs {type: ndarray} or None, new log lines) or
         P ("error", kind, message, fatal, new log lines), kind "description" or "execution".
"""

from __future__ import annotations

import ctypes
import os
import pickle
import signal
import struct
import sys

_HEADER = struct.Struct("<I")
STEP, PICKLED, OUTPUTS = b"S", b"P", b"O"
TYPES = ("Real", "Integer", "Boolean")  # connections.TYPES: the order outputs travel in
_TIMES = struct.Struct("<dd")
_SET = struct.Struct("<cI")
_DTYPE = {"Real": "<f8", "Integer": "<i4", "Boolean": "<i4"}  # fmi2Real, fmi2Integer, fmi2Boolean (an int)
_CODE = {"Real": b"R", "Integer": b"I", "Boolean": b"B"}
_TYPE = {c: t for t, c in _CODE.items()}


def send_bytes(fd: int, data: bytes) -> None:
    view = memoryview(_HEADER.pack(len(data)) + data)
    while view:
        view = view[os.write(fd, view):]


def send(fd: int, obj) -> None:
    send_bytes(fd, PICKLED + pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL))


def encode_step(sets, t: float, h: float) -> bytes:
    """sets: [(type, n, value references as uint32 bytes, values as fmi2 bytes)] in native byte order."""
    parts = [STEP, _TIMES.pack(t, h)]
    for typ, n, vrs, values in sets:
        parts += [_SET.pack(_CODE[typ], n), vrs, values]
    return b"".join(parts)


def decode_step(body: bytes):
    """(sets [(type, vrs bytes, values bytes, n)], t, h) of a step request."""
    t, h = _TIMES.unpack_from(body, 1)
    at, sets = 1 + _TIMES.size, []
    while at < len(body):
        code, n = _SET.unpack_from(body, at)
        at += _SET.size
        typ = _TYPE[code]
        width = 8 if typ == "Real" else 4
        sets.append((typ, body[at:at + 4 * n], body[at + 4 * n:at + 4 * n + width * n], n))
        at += 4 * n + width * n
    return sets, t, h


def encode_outputs(values: dict, log: list) -> bytes:
    return b"".join([OUTPUTS, *(values[t].tobytes() for t in TYPES), pickle.dumps(log) if log else b""])


def decode_outputs(body: bytes, targets: dict) -> list:
    """Copy the outputs of a raw reply into targets {type: ndarray}; return the log lines that came with them."""
    import numpy as np

    at = 1
    for t in TYPES:
        n = targets[t].size * targets[t].itemsize
        targets[t][:] = np.frombuffer(body, dtype=_DTYPE[t], count=targets[t].size, offset=at)
        at += n
    return pickle.loads(body[at:]) if at < len(body) else []


def receive_exact(fd: int, n: int) -> bytes | None:
    """n bytes from fd, or None at end of file (the other side is gone)."""
    chunks, left = [], n
    while left:
        chunk = os.read(fd, left)
        if not chunk:
            return None
        chunks.append(chunk)
        left -= len(chunk)
    return b"".join(chunks)


def _die_with_parent() -> None:
    """Linux: be killed when the master dies, even while hung inside the FMU."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass  # elsewhere a dead master still closes the request pipe, which ends the loop


def serve(fmu: str, name: str, requests: int, replies: int) -> int:
    from .execution import _C_TYPE, ExecutionError, FmuInstance, read_fmu
    from .system import DescriptionError

    inst, sent = None, 0

    def new_log():
        nonlocal sent
        lines = inst.log[sent:] if inst is not None else []
        sent += len(lines)
        return lines

    def outputs():
        return {t: v.copy() for t, v in inst.values.items()}

    vr_arrays: dict[bytes, object] = {}  # the value-reference arrays of each set, built once

    def apply(typ: str, vrs: bytes, values: bytes, n: int, t: float) -> None:
        key = _CODE[typ] + vrs
        if key not in vr_arrays:
            vr_arrays[key] = (ctypes.c_uint * n).from_buffer_copy(vrs)
        status = inst.setters[typ](inst.component, vr_arrays[key], n, (_C_TYPE[typ] * n).from_buffer_copy(values))
        if status > 1:
            raise inst.failed(f"set{typ} at t={t:.6g} s", status)

    try:
        inst = FmuInstance(name, fmu, read_fmu(fmu, name))
        send(replies, ("ok", None, new_log()))
    except (ExecutionError, DescriptionError) as err:
        send(replies, ("error", "execution", str(err), False, new_log()))
        return 1
    while True:
        header = receive_exact(requests, _HEADER.size)
        if header is None:
            break  # the master is gone
        body = receive_exact(requests, _HEADER.unpack(header)[0])
        if body is None:
            break
        request = pickle.loads(body[1:]) if body[:1] == PICKLED else ("step",)
        op = request[0]
        try:
            if op == "step":
                sets, t, h = decode_step(body)
                for typ, vrs, values, n in sets:
                    apply(typ, vrs, values, n, t)
                inst.do_step(t, h)
                inst.read_outputs()
                send_bytes(replies, encode_outputs(inst.values, new_log()))
            elif op == "init":
                inst.initialize(request[1])
                send(replies, ("ok", outputs(), new_log()))
            elif op == "reset":
                inst.reset()
                send(replies, ("ok", None, new_log()))
            elif op == "close":
                inst.close()
                send(replies, ("ok", None, new_log()))
                break
        except DescriptionError as err:
            send(replies, ("error", "description", str(err), inst.fatal, new_log()))
        except ExecutionError as err:
            send(replies, ("error", "execution", str(err), inst.fatal, new_log()))
    return 0


def main() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the master's to handle; it closes us
    _die_with_parent()
    fmu, name, requests, replies = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
    code = serve(fmu, name, requests, replies)
    from .pythonfmu_guard import exit_now

    exit_now(code)  # no interpreter shutdown: a pythonfmu FMU can crash in it


if __name__ == "__main__":
    main()

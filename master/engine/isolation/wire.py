"""The wire format between the master and an FMU's worker process: length-prefixed messages.

The step, the hot path, is raw bytes (encode_step / encode_outputs: no pickling per tick); every
other message is pickled, after a b"P". Requests:
  step                          apply sets [(type, vrs, values)], doStep(t, h); reply: the outputs
  P ("init", parameters)        initialization; reply: the outputs at t = 0
  P ("reset",)                  fmi2Reset
  P ("set", {name: value})      set parameters or inputs
  P ("get_state",)              the serialized FMU state; reply: P ("ok", state bytes, log)
  P ("set_state", state)        restore it; reply: the outputs
  P ("close",)                  terminate, free, exit
Replies: the outputs as raw bytes (plus new log lines, pickled, when there are any), or
         P ("ok", outputs {type: ndarray} or None, new log lines) or
         P ("error", kind, message, fatal, new log lines), kind "description" or "execution".
Values travel in the FMI types' native layout: fmi2Real as float64, fmi2Integer and fmi2Boolean as int32.
"""

from __future__ import annotations

import os
import pickle
import struct

HEADER = struct.Struct("<I")  # the length of the message that follows
STEP, PICKLED, OUTPUTS = b"S", b"P", b"O"
TYPES = ("Real", "Integer", "Boolean")  # the order outputs travel in (slave.TYPES)
_TIMES = struct.Struct("<dd")
_SET = struct.Struct("<cI")
_DTYPE = {"Real": "<f8", "Integer": "<i4", "Boolean": "<i4"}
_CODE = {"Real": b"R", "Integer": b"I", "Boolean": b"B"}
_TYPE = {c: t for t, c in _CODE.items()}


def type_code(typ: str) -> bytes:
    return _CODE[typ]


def send_bytes(fd: int, data: bytes) -> None:
    view = memoryview(HEADER.pack(len(data)) + data)
    while view:
        view = view[os.write(fd, view):]


def send(fd: int, obj) -> None:
    send_bytes(fd, PICKLED + pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL))


def unpickle(body: bytes):
    """The object of a pickled message (body starts with PICKLED)."""
    return pickle.loads(body[1:])


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

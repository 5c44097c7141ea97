"""A process that hosts one FMU for the master (`python -m tiltload.master.fmu_worker`).

An FMU that is not ours can crash (segfault), call exit() or hang. In its own process that
costs the process, not the run: the master sees the pipe close or its watchdog expire and says
so in one line, with the log it has written so far intact. See fmu_process.py for the master's side.

Protocol: length-prefixed pickles on two pipes the master passes by number. Requests:
  ("init", parameters)          initialization; reply: the outputs at t = 0
  ("step", sets, t, h)          apply sets [(type, vrs, values)], doStep(t, h); reply: the outputs
  ("reset",)                    fmi2Reset
  ("close",)                    terminate, free, exit
Replies: ("ok", outputs {type: ndarray} or None, new log lines) or
         ("error", kind, message, fatal, new log lines), kind "description" or "execution".
"""

from __future__ import annotations

import ctypes
import os
import pickle
import signal
import struct
import sys

_HEADER = struct.Struct("<I")


def send(fd: int, obj) -> None:
    data = pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL)
    view = memoryview(_HEADER.pack(len(data)) + data)
    while view:
        view = view[os.write(fd, view):]


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
    import numpy as np

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
        request = pickle.loads(receive_exact(requests, _HEADER.unpack(header)[0]))
        op = request[0]
        try:
            if op == "step":
                _, sets, t, h = request
                component = inst.component
                for typ, vrs, values in sets:
                    n = len(vrs)
                    status = inst.setters[typ](component, (ctypes.c_uint * n)(*vrs.tolist()), n,
                                               values.astype(np.dtype(_C_TYPE[typ])).ctypes.data_as(ctypes.POINTER(_C_TYPE[typ])))
                    if status > 1:
                        raise inst.failed(f"set{typ} at t={t:.6g} s", status)
                inst.do_step(t, h)
                inst.read_outputs()
                send(replies, ("ok", outputs(), new_log()))
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

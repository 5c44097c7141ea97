"""A process that hosts one FMU for the master (`python -m tiltload.master.engine.isolation.worker`).

An FMU that is not trusted can crash (segfault), call exit() or hang. In its own process that
costs the process, not the run: the master sees the pipe close or its watchdog expire and says
so in one line, with the log it has written so far intact. See process.py for the master's side
and wire.py for the messages.
"""

from __future__ import annotations

import ctypes
import signal
import sys

from . import wire


def _die_with_parent() -> None:
    """Linux: be killed when the master dies, even while hung inside the FMU."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass  # elsewhere a dead master still closes the request pipe, which ends the loop


def serve(fmu: str, name: str, requests: int, replies: int) -> int:
    from ..errors import DescriptionError, ExecutionError
    from ..fmu import InProcessFmu
    from ..model_description import read_fmu
    from ..slave import C_TYPES

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
        key = wire.type_code(typ) + vrs
        if key not in vr_arrays:
            vr_arrays[key] = (ctypes.c_uint * n).from_buffer_copy(vrs)
        status = inst.setters[typ](inst.component, vr_arrays[key], n, (C_TYPES[typ] * n).from_buffer_copy(values))
        if status > 1:
            raise inst.failed(f"set{typ} at t={t:.6g} s", status)

    try:
        inst = InProcessFmu(name, fmu, read_fmu(fmu, name))
        wire.send(replies, ("ok", None, new_log()))
    except (ExecutionError, DescriptionError) as err:
        wire.send(replies, ("error", "execution", str(err), False, new_log()))
        return 1
    while True:
        header = wire.receive_exact(requests, wire.HEADER.size)
        if header is None:
            break  # the master is gone
        body = wire.receive_exact(requests, wire.HEADER.unpack(header)[0])
        if body is None:
            break
        request = wire.unpickle(body) if body[:1] == wire.PICKLED else ("step",)
        op = request[0]
        try:
            if op == "step":
                sets, t, h = wire.decode_step(body)
                for typ, vrs, values, n in sets:
                    apply(typ, vrs, values, n, t)
                inst.do_step(t, h)
                inst.read_outputs()
                wire.send_bytes(replies, wire.encode_outputs(inst.values, new_log()))
            elif op == "init":
                inst.initialize(request[1])
                wire.send(replies, ("ok", outputs(), new_log()))
            elif op == "set":
                inst.set_parameters(request[1])
                wire.send(replies, ("ok", None, new_log()))
            elif op == "get_state":
                wire.send(replies, ("ok", inst.get_state(), new_log()))
            elif op == "set_state":
                inst.set_state(request[1])
                wire.send(replies, ("ok", outputs(), new_log()))
            elif op == "reset":
                inst.reset()
                wire.send(replies, ("ok", None, new_log()))
            elif op == "close":
                inst.close()
                wire.send(replies, ("ok", None, new_log()))
                break
        except DescriptionError as err:
            wire.send(replies, ("error", "description", str(err), inst.fatal, new_log()))
        except ExecutionError as err:
            wire.send(replies, ("error", "execution", str(err), inst.fatal, new_log()))
    return 0


def main() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the master's to handle; it closes us
    _die_with_parent()
    fmu, name, requests, replies = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
    code = serve(fmu, name, requests, replies)
    from ..pythonfmu_guard import exit_now

    exit_now(code)  # no interpreter shutdown: a pythonfmu FMU can crash in it


if __name__ == "__main__":
    main()

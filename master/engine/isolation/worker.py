"""A process that hosts one FMU for the master (its command line: `python -m tiltload.master.command_line.worker`).

An FMU that is not trusted can crash (segfault), call exit() or hang. In its own process that
costs the process, not the run: the master sees the link close or its watchdog expire and says
so in one line, with the log it has written so far intact. The link is a pipe pair to a local
master (--pipes) or a TCP connection `tiltload serve` accepted and authenticated (--socket,
server.py); the messages are the same (wire.py), and every request is checked against the model
before it reaches the FMU. See process.py for the master's side.
"""

from __future__ import annotations

import ctypes
import sys

from ..errors import FmuEndedRun
from . import wire
from .link import HostLink, LinkRefused
from .transport import Channel, FrameTooLarge, LinkClosed, LinkTimeout


def labelled(label: str):
    """say(message): a line on stderr, after the label if there is one."""
    def say(message: str) -> None:
        print(f"{label}: {message}" if label else message, file=sys.stderr, flush=True)
    return say


def model_inputs(md) -> dict[str, frozenset]:
    """{type: value references of the model's inputs}: what a step may set."""
    return {t: frozenset(v.valueReference for v in md.modelVariables if v.causality == "input" and v.type == t)
            for t in wire.TYPES}


def serve(fmu: str, name: str, channel: Channel, idle_timeout: float | None = None, say=None, tick: float | None = None,
          loader=None, shm: int | None = None) -> int:
    """Instantiate the FMU (FMI 2.0 or 3.0; tick: the master's, for an FMU with clocks), answer the master's requests
    until it closes the link or asks to close. loader(name, fmu, md, tick): the slave that answers (default: the FMU
    loaded in this process; another model of the same ports, e.g. a controller's prototype in Python). shm: the
    master's shared-memory segment (link.py): on its "link" request the steps go through it, answered in C, until it
    yields."""
    from ..errors import DescriptionError, ExecutionError
    from ..fmi.in_process import load
    from ..fmi.model_description import read_fmu
    from ..fmi.slave import C_TYPES

    say = say or labelled("")
    inst, sent = None, 0

    def new_log():
        nonlocal sent
        lines = inst.log[sent:] if inst is not None else []
        sent += len(lines)
        return lines

    def texts():
        """The String and Binary outputs now, as a reply carries them (None for a model without any)."""
        if not inst.text_outputs:
            return None
        inst.read_texts()
        try:
            return wire.encode_texts(inst.texts)
        except ValueError as err:
            raise ExecutionError(f"{name}: {err}") from None

    def outputs() -> bytes:
        read = texts()  # before the log lines: a get's own lines go with this reply
        return wire.encode_outputs(inst.values, new_log(), read)

    arrays: dict[bytes, tuple] = {}  # each set's value-reference and value arrays, built once: the same call site each
    # step, as in the master (an FMI 3.0 slave with clocks stages its inputs by call site)

    def apply(typ: str, vrs: bytes, values: bytes, n: int, t: float) -> None:
        key = wire.type_code(typ) + vrs
        if key not in arrays:
            arrays[key] = ((ctypes.c_uint * n).from_buffer_copy(vrs), (C_TYPES[typ] * n)())
        vr_array, buffer = arrays[key]
        ctypes.memmove(buffer, values, len(values))
        status = inst.setters[typ](inst.component, vr_array, n, buffer)
        if status > 1:
            raise inst.failed(f"set{typ} at t={t:.6g} s", status)

    try:
        md = read_fmu(fmu, name)
        inst = (loader or load)(name, fmu, md, tick)
        channel.send(wire.ok(new_log()))
    except (ExecutionError, DescriptionError) as err:
        channel.send(wire.error("execution", str(err), False, new_log()))
        return 1
    inputs = model_inputs(md)

    def initialize(parameters: dict, sets, start: float, texts: dict | None = None) -> None:
        """Initialization at start (the system's start time); sets and texts (the connected inputs at the start, the
        numbers' and the String and Binary ones', or None): set in Initialization Mode where the FMU takes them there,
        as the master does in its own process, else after it, the outputs read again."""
        def connect():
            for typ, vrs, values, n in sets or ():
                apply(typ, vrs, values, n, start)
            if texts:
                inst.set_values(texts)
        at = {"start": start} if start else {}  # a slave of its own (loader) may take no start: it has none but 0
        if sets is None and not texts:
            inst.initialize(parameters, **at)
        elif getattr(inst, "connects_in_initialization", False):
            inst.initialize(parameters, connect=connect, **at)
        else:
            inst.initialize(parameters, **at)
            connect()
            inst.read_outputs()
    step_limit = wire.step_limit(inputs)
    serializes = inst.can_serialize  # only then may a peer send a state (up to wire.STATE_LIMIT bytes)
    frame_limit = max(step_limit, wire.CONTROL_LIMIT + 2 * step_limit,  # an init carries inputs too
                       wire.STATE_FRAME_LIMIT if serializes else 0)
    checked: set = set()
    host_link = None
    while True:
        try:
            body = channel.receive(idle_timeout, frame_limit)
        except LinkClosed:
            break  # the master is gone
        except LinkTimeout:
            say(f"no request for {idle_timeout:g} s: session ended")
            return 1
        except FrameTooLarge as err:
            say(f"refused {err}: session ended")
            return 1
        try:
            if body[:1] == wire.STEP:
                if len(body) > step_limit:
                    raise wire.ProtocolError(f"a step of {len(body)} bytes, this model's are at most {step_limit}")
                sets, t, h = wire.decode_step(body, inputs, checked)
                for typ, vrs, values, n in sets:
                    apply(typ, vrs, values, n, t)
                try:
                    inst.do_step(t, h)
                except FmuEndedRun as end:  # not a failure: the master ends the run there, with these outputs
                    inst.read_outputs()
                    read = texts()
                    channel.send(wire.encode_ended(end.time, str(end.failure), inst.values, new_log(), read))
                    continue
                inst.read_outputs()
                channel.send(outputs())
                continue
            if body[:1] == wire.STATE:
                if not serializes:
                    raise wire.ProtocolError("a state for an FMU that cannot serialize its state")
                state, _ = wire.decode_state(body)
                inst.set_state(state)
                channel.send(outputs())
                continue
            request = wire.decode_control(body)
            op = request.get("op")
            if op == "init" and isinstance(request.get("parameters"), dict):
                initialize(request["parameters"], wire.decode_inputs(request["inputs"], inputs)
                           if "inputs" in request else None, wire.start_time(request), wire.init_texts(request))
                channel.send(outputs())
            elif op == "set" and isinstance(request.get("values"), dict):
                inst.set_values(request["values"])
                channel.send(wire.ok(new_log()))
            elif op == "get_state" and serializes:
                state = inst.get_state()
                if len(state) > wire.STATE_LIMIT:
                    raise ExecutionError(f"{name}: its state is {len(state)} bytes, over the {wire.STATE_LIMIT >> 20} MiB "
                                         "a state may have on the link")
                channel.send(wire.encode_state(state, new_log()))
            elif op == "link" and shm is not None and hasattr(inst, "function_pointer"):
                if host_link is None:
                    host_link = HostLink(shm, channel.read_fd)
                host_link.bind(inst, request, inputs)
                channel.send(wire.ok(new_log()))
                if not host_link.serve():
                    break  # the master is gone
                channel.send(wire.ok(new_log()))  # the master yielded: its next request comes on the pipe
            elif op == "reset":
                inst.reset()
                if host_link is not None:
                    host_link.forget_inputs()
                channel.send(wire.ok(new_log()))
            elif op == "close":
                inst.close()
                channel.send(wire.ok(new_log()))
                break
            else:
                raise wire.ProtocolError(f"unknown request {str(op)[:40]!r}")
        except (wire.ProtocolError, LinkRefused) as err:
            say(f"protocol error: {err}: session ended")
            try:
                channel.send(wire.error("protocol", str(err), False, []))
            except LinkClosed:
                pass
            return 1
        except LinkClosed:
            break
        except DescriptionError as err:
            channel.send(wire.error("description", str(err), inst.fatal, new_log()))
        except ExecutionError as err:
            channel.send(wire.error("execution", str(err), inst.fatal, new_log()))
    return 0

"""The messages between the master and an FMU's host (a worker process, or `tiltload serve` across the network).

Every message is one frame (transport.py). The step, the hot path, is raw bytes; the rare ones are
JSON after a b"J" (never pickle: a host must not run what a peer sends it). Requests:
  S t h {type n vrs values}     apply the sets, doStep(t, h); reply: the outputs
  J {"op": "init", "parameters": {name: value}[, "inputs": base64 of an S frame's sets][, "texts": {name: text}]
     [, "start": t0]}
                                initialization, the connected inputs (if sent) set in Initialization Mode (or, for
                                a host whose FMU cannot take them there, after it); reply: the outputs at t = 0
  J {"op": "reset"}             fmi2Reset
  J {"op": "set", "values": {name: value}}        set parameters or inputs by name
  J {"op": "get_state"}         the FMU's serialized state; reply: T state
  T n state                     restore a state get_state gave (n bytes); reply: the outputs
  J {"op": "close"}             terminate, free, exit
Replies: O outputs [log lines as JSON]           the outputs, raw, plus the FMU's new log lines if any; an FMU with
                                                 String or Binary outputs: {"log": [...], "texts": {name: value}}
                                                 instead, a Binary's value in hexadecimal (TEXT_LIMIT bytes at most)
         E t n failure outputs [log lines]       a step's: the FMU ended the run at t, its outputs there (valid);
                                                 failure (n bytes): what the request is where a system takes it as one
         T n state [log lines as JSON]           the FMU's serialized state (n bytes, STATE_LIMIT at most)
         J {"ok": true, "log": [...]}
         J {"error": kind, "message": ..., "fatal": bool, "log": [...]}  kind: description, execution, protocol
Values travel in the FMI types' layout, little-endian: fmi2Real as float64, fmi2Integer and fmi2Boolean as int32.
Every frame is checked against the model's sizes (step_limit, reply_limit) and its content against the model
(decode_step: only the model's inputs, only whole sets), so a peer that sends garbage gets a ProtocolError.
"""

from __future__ import annotations

import base64
import json
import struct

import numpy as np

STEP, CONTROL, OUTPUTS, STATE, ENDED = b"S", b"J", b"O", b"T", b"E"
TYPES = ("Real", "Integer", "Boolean")  # the order outputs travel in (slave.TYPES)
WIDTH = {"Real": 8, "Integer": 4, "Boolean": 4}
LOG_LIMIT = 256 * 1024  # bytes of log lines one reply carries at most (the rest is summarized in one line)
CONTROL_LIMIT = 1 << 20  # bytes of a JSON request (an initialization's parameters) or error reply
STATE_LIMIT = 64 << 20  # bytes of an FMU's serialized state (a snapshot's), either way
TEXT_LIMIT = 1 << 20  # bytes of a reply's String and Binary outputs, as JSON
_STATE_SIZE = struct.Struct("<Q")
STATE_FRAME_LIMIT = 1 + _STATE_SIZE.size + STATE_LIMIT + LOG_LIMIT + 1024  # a T frame, with its log lines
_TIMES = struct.Struct("<dd")
_SET = struct.Struct("<cI")
_DTYPE = {"Real": "<f8", "Integer": "<i4", "Boolean": "<i4"}
_CODE = {"Real": b"R", "Integer": b"I", "Boolean": b"B"}
_TYPE = {c: t for t, c in _CODE.items()}


class ProtocolError(Exception):
    """A frame that is not a message of this protocol, or not one for this model."""


def type_code(typ: str) -> bytes:
    return _CODE[typ]


def _json_default(value):
    if isinstance(value, np.generic):  # a numpy scalar among the parameters
        return value.item()
    if isinstance(value, (bytes, bytearray)):  # a Binary value: in hexadecimal, as checked_value reads it
        return value.hex()
    raise TypeError(f"{type(value).__name__} cannot travel to an FMU's host")


def control(message: dict) -> bytes:
    return CONTROL + json.dumps(message, default=_json_default, allow_nan=False).encode()


MAX_DEPTH = 16  # nesting of a message's JSON: ours go 3 deep; a deeper one is refused before it is parsed


def _nesting(data: bytes) -> int:
    """How deep JSON's arrays and objects nest in data (brackets inside strings not counted)."""
    if data.count(b"[") + data.count(b"{") <= MAX_DEPTH:  # the common case: no scan
        return 0
    depth = deepest = 0
    in_string = escaped = False
    for c in data:
        if in_string:
            if escaped:
                escaped = False
            elif c == 0x5C:  # backslash
                escaped = True
            elif c == 0x22:
                in_string = False
        elif c == 0x22:
            in_string = True
        elif c in (0x5B, 0x7B):
            depth += 1
            deepest = max(deepest, depth)
        elif c in (0x5D, 0x7D):
            depth -= 1
    return deepest


def loads(data: bytes, what: str):
    """JSON from a peer, its nesting bounded before it is parsed; a ProtocolError naming what it should have been."""
    if _nesting(data) > MAX_DEPTH:
        raise ProtocolError(f"malformed {what} (JSON nested deeper than {MAX_DEPTH})")
    try:
        return json.loads(data.decode())
    except (UnicodeDecodeError, ValueError, RecursionError) as err:
        raise ProtocolError(f"malformed {what} ({err})") from None


def decode_control(body: bytes) -> dict:
    """The JSON object of a b"J" frame, or a ProtocolError."""
    if body[:1] != CONTROL:
        raise ProtocolError(f"expected a J message, got {body[:1]!r}")
    message = loads(body[1:], "J message")
    if not isinstance(message, dict):
        raise ProtocolError("malformed J message (not an object)")
    return message


def fitting_log(lines: list[str]) -> list[str]:
    """The log lines one reply carries: at most LOG_LIMIT bytes of JSON, what does not fit said in one last line."""
    size = 2
    for i, line in enumerate(lines):
        size += len(json.dumps(line)) + 1
        if size > LOG_LIMIT:
            return [*lines[:i], f"[{len(lines) - i} more log lines not sent: over {LOG_LIMIT} bytes in one reply]"]
    return list(lines)


def _decode_log(lines) -> list[str]:
    if not isinstance(lines, list) or not all(isinstance(x, str) for x in lines):
        raise ProtocolError("malformed log lines (not a list of strings)")
    return lines


def ok(log: list[str]) -> bytes:
    return control({"ok": True, "log": fitting_log(log)})


def error(kind: str, message: str, fatal: bool, log: list[str]) -> bytes:
    return control({"error": kind, "message": message[:4096], "fatal": bool(fatal), "log": fitting_log(log)})


def encode_step(sets, t: float, h: float) -> bytes:
    """sets: [(type, n, value references as uint32 bytes, values as fmi2 bytes)]."""
    parts = [STEP, _TIMES.pack(t, h)]
    for typ, n, vrs, values in sets:
        parts += [_SET.pack(_CODE[typ], n), vrs, values]
    return b"".join(parts)


def encode_inputs(sets) -> str:
    """The connected inputs an init request carries: the sets of a step (encode_step's) in base64."""
    return base64.b64encode(encode_step(sets, 0.0, 0.0)).decode()


def decode_inputs(text, inputs: dict[str, frozenset]):
    """The sets [(type, vrs bytes, values bytes, n)] of an init request's "inputs", checked as a step's are."""
    if not isinstance(text, str):
        raise ProtocolError("malformed init request (its inputs are not a string)")
    try:
        body = base64.b64decode(text.encode(), validate=True)
    except ValueError:
        raise ProtocolError("malformed init request (its inputs are not base64)") from None
    if body[:1] != STEP:
        raise ProtocolError("malformed init request (its inputs are not a step's sets)")
    return decode_step(body, inputs)[0]


def init_texts(request: dict) -> dict | None:
    """An init request's String and Binary inputs {name: text} (a Binary's in hexadecimal), or None; each checked
    against its variable where it is set (checked_value)."""
    texts = request.get("texts")
    if texts is None:
        return None
    if not isinstance(texts, dict) or not all(isinstance(k, str) and isinstance(v, str) for k, v in texts.items()):
        raise ProtocolError("malformed init request (its texts are not names and strings)")
    return texts


def start_time(request: dict) -> float:
    """An init request's start time (0 when it names none), checked: a finite time of 0 s or later."""
    t0 = request.get("start", 0.0)
    if isinstance(t0, bool) or not isinstance(t0, (int, float)) or not 0 <= t0 < float("inf"):
        raise ProtocolError("malformed init request (its start is not a time of 0 s or later)")
    return float(t0)


def step_limit(inputs: dict[str, frozenset]) -> int:
    """The longest step a model can be sent: each input at most twice (its connection and a fault's hold),
    each in a set of its own at worst."""
    return 1 + _TIMES.size + sum(2 * len(vrs) * (_SET.size + 4 + WIDTH[t]) for t, vrs in inputs.items())


def decode_step(body: bytes, inputs: dict[str, frozenset], checked: set | None = None):
    """(sets [(type, vrs bytes, values bytes, n)], t, h) of a step request whose sets name only the model's
    inputs (inputs: {type: value references}); a ProtocolError otherwise. checked: the sets' value references
    found good before (type code + vrs bytes), not checked again."""
    if len(body) < 1 + _TIMES.size:
        raise ProtocolError(f"a step of {len(body)} bytes is too short")
    t, h = _TIMES.unpack_from(body, 1)
    at, sets = 1 + _TIMES.size, []
    while at < len(body):
        if at + _SET.size > len(body):
            raise ProtocolError("a step ends inside a set's header")
        code, n = _SET.unpack_from(body, at)
        at += _SET.size
        typ = _TYPE.get(code)
        if typ is None:
            raise ProtocolError(f"a step sets values of unknown type {code!r}")
        end = at + (4 + WIDTH[typ]) * n
        if end > len(body):
            raise ProtocolError(f"a step announces {n} {typ} values and ends before them")
        vrs = body[at:at + 4 * n]
        if checked is None or code + vrs not in checked:
            allowed = inputs.get(typ, frozenset())
            if any(vr not in allowed for vr in np.frombuffer(vrs, dtype="<u4").tolist()):
                raise ProtocolError(f"a step sets a {typ} that is not an input of this model")
            if checked is not None:
                checked.add(code + vrs)
        sets.append((typ, vrs, body[at + 4 * n:end], n))
        at = end
    return sets, t, h


def output_bytes(counts: dict[str, int]) -> int:
    return sum(WIDTH[t] * counts.get(t, 0) for t in TYPES)


def reply_limit(counts: dict[str, int], texts: bool = False) -> int:
    """The longest reply a model's host may send: its outputs (texts: with String or Binary ones; an end of the run's
    with its time and failure line) or an error, plus a bounded log."""
    ended = _ENDED.size + _FAILURE_LIMIT + 64
    return max(1 + ended + output_bytes(counts) + (TEXT_LIMIT if texts else 0), CONTROL_LIMIT) + LOG_LIMIT + 1024


def encode_texts(texts: dict) -> dict[str, str]:
    """String and Binary outputs {name: str or bytes} as a reply carries them (a Binary in hexadecimal); a ValueError if
    they take more than TEXT_LIMIT bytes."""
    out = {name: value.hex() if isinstance(value, (bytes, bytearray)) else str(value) for name, value in texts.items()}
    if len(json.dumps(out)) > TEXT_LIMIT:
        raise ValueError(f"its String and Binary outputs take over {TEXT_LIMIT} bytes, more than a reply carries")
    return out


def encode_outputs(values: dict, log: list, texts: dict | None = None) -> bytes:
    """texts: the String and Binary outputs (encode_texts), for a model that has any."""
    trailer = json.dumps({"log": fitting_log(log), "texts": texts}) if texts is not None else \
        json.dumps(fitting_log(log)) if log else ""
    return b"".join([OUTPUTS, *(values[t].astype(_DTYPE[t], copy=False).tobytes() for t in TYPES), trailer.encode()])


_ENDED = struct.Struct("<dI")  # the time, the failure's length
_FAILURE_LIMIT = 4096


def encode_ended(t: float, failure: str, values: dict, log: list, texts: dict | None = None) -> bytes:
    """A step's reply when the FMU ended the run (FmuEndedRun) at t: its outputs there, the last valid ones, and the
    failure's line (for a system that takes the request as a failure)."""
    text = failure.encode("utf-8", "replace")[:_FAILURE_LIMIT]
    return ENDED + _ENDED.pack(t, len(text)) + text + encode_outputs(values, log, texts)[1:]


def decode_ended(body: bytes, targets: dict, texts: dict | None = None) -> tuple[float, str, list]:
    """(the time the FMU ended the run, the failure's line, log lines) of an E reply, its outputs copied into targets
    (and texts, decode_outputs)."""
    if len(body) < 1 + _ENDED.size:
        raise ProtocolError(f"an end of the run of {len(body)} bytes")
    t, n = _ENDED.unpack_from(body, 1)
    at = 1 + _ENDED.size
    if n > _FAILURE_LIMIT or at + n > len(body):
        raise ProtocolError(f"an end of the run announces a failure of {n} bytes and has {len(body) - at}")
    return t, body[at:at + n].decode("utf-8", "replace"), decode_outputs(OUTPUTS + body[at + n:], targets, texts)


def decode_outputs(body: bytes, targets: dict, texts: dict | None = None) -> list:
    """Copy the outputs of a raw reply into targets {type: ndarray} (its String and Binary outputs, {name: text},
    into texts); return the log lines that came with them."""
    at = 1
    size = 1 + sum(targets[t].size * WIDTH[t] for t in TYPES)
    if len(body) < size:
        raise ProtocolError(f"outputs of {len(body)} bytes, the model has {size - 1}")
    for t in TYPES:
        n = targets[t].size
        targets[t][:] = np.frombuffer(body, dtype=_DTYPE[t], count=n, offset=at)
        at += n * WIDTH[t]
    if at == len(body):
        return []
    trailer = loads(body[at:], "log lines")
    if isinstance(trailer, dict):
        received = trailer.get("texts")
        if not isinstance(received, dict) or not all(isinstance(x, str) for x in received.values()):
            raise ProtocolError("malformed String and Binary outputs (not an object of strings)")
        if texts is not None:
            texts.update(received)
        trailer = trailer.get("log", [])
    return _decode_log(trailer)


def decode_reply(body: bytes) -> dict:
    """A J reply: {"ok": True, "log": [...]} or {"error": kind, "message", "fatal", "log"}, checked."""
    reply = decode_control(body)
    reply["log"] = _decode_log(reply.get("log", []))
    if reply.get("ok") is True:
        return reply
    if not (isinstance(reply.get("error"), str) and isinstance(reply.get("message"), str)):
        raise ProtocolError("malformed reply (neither ok nor an error)")
    return reply


def encode_state(state: bytes, log: list | None = None) -> bytes:
    """A serialized FMU state (a set_state request, or get_state's reply with the FMU's new log lines)."""
    if len(state) > STATE_LIMIT:
        raise ProtocolError(f"an FMU state of {len(state)} bytes, over the {STATE_LIMIT >> 20} MiB a state may have")
    return b"".join([STATE, _STATE_SIZE.pack(len(state)), state, json.dumps(fitting_log(log)).encode() if log else b""])


def decode_state(body: bytes) -> tuple[bytes, list]:
    """(state, log lines) of a T frame, or a ProtocolError."""
    if body[:1] != STATE or len(body) < 1 + _STATE_SIZE.size:
        raise ProtocolError(f"expected a state (T message), got {len(body)} bytes starting {body[:1]!r}")
    (n,) = _STATE_SIZE.unpack_from(body, 1)
    at = 1 + _STATE_SIZE.size
    if n > STATE_LIMIT or at + n > len(body):
        raise ProtocolError(f"a state announces {n} bytes and the message has {len(body) - at}")
    state, rest = body[at:at + n], body[at + n:]
    if not rest:
        return state, []
    return state, _decode_log(loads(rest, "log lines"))

"""An FMI 3.0 slave's state between two steps (fmi3.py's save_state, get_state): the FMU's serialized state and what
the slave holds besides (the clocked outputs as read at their clocks' last ticks, a pending event), as plain bytes for
a snapshot: no pickle, a one-line error for bytes that are not one."""

from __future__ import annotations

import json
import struct
from dataclasses import dataclass

import numpy as np

from ..errors import ExecutionError

STATE_MAGIC = b"TLFMU3S1"  # get_state's bytes: magic, header length (u32 LE), JSON header, the FMU's state, held outputs


@dataclass
class Fmu3State:
    """A slave between two steps: the FMU's serialized state and what the slave holds (held outputs, a pending event)."""

    fmu: bytes
    values: dict[str, np.ndarray]
    held: list[np.ndarray]  # the clocked outputs as read at their clocks' last ticks
    event_asked: bool
    next_event: float | None

    def to_bytes(self) -> bytes:
        """Plain bytes (no pickle): a JSON header with the flags and the held arrays' layout, then the raw data."""
        header = json.dumps({"fmu": len(self.fmu), "held": [[a.dtype.str, a.size] for a in self.held],
                             "event_asked": self.event_asked, "next_event": self.next_event}).encode()
        return b"".join([STATE_MAGIC, struct.pack("<I", len(header)), header, self.fmu,
                         *(a.astype(a.dtype.newbyteorder("<"), copy=False).tobytes() for a in self.held)])

    @classmethod
    def from_bytes(cls, data: bytes, name: str) -> Fmu3State:
        """The state to_bytes wrote (values are the snapshot's business: empty here); a one-line error otherwise."""
        try:
            if data[:8] != STATE_MAGIC:
                raise ValueError("not an FMI 3.0 slave's state")
            (n,) = struct.unpack_from("<I", data, 8)
            header = json.loads(data[12:12 + n])
            at = 12 + n
            if len(data) != at + header["fmu"] + sum(np.dtype(d).itemsize * size for d, size in header["held"]):
                raise ValueError("its length does not match its header")
            fmu = data[at:at + header["fmu"]]
            at += header["fmu"]
            held = []
            for dtype, size in header["held"]:
                dt = np.dtype(dtype)
                held.append(np.frombuffer(data, dtype=dt, count=size, offset=at).astype(dt.newbyteorder("="), copy=True))
                at += dt.itemsize * size
            return cls(fmu, {}, held, bool(header["event_asked"]), header["next_event"])
        except (ValueError, KeyError, TypeError, struct.error, json.JSONDecodeError, UnicodeDecodeError) as err:
            raise ExecutionError(f"{name}: cannot restore its state: {err}") from None

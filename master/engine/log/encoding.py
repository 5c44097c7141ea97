"""A protobuf message per FMU instance whose every field is present, in field-number order.

Every field number is in 16..2047, so every tag is two bytes, and a message has a fixed layout:
10 bytes per double (the time and the Real outputs), 6 per sfixed32 (Integer outputs), 3 per bool
(Boolean outputs). Encoding a step is then three strided numpy copies into a preset buffer, about
a microsecond for a hundred values, and any protobuf reader (Foxglove's included) decodes it with
the schema: a FileDescriptorSet built with the protobuf library.
"""

from __future__ import annotations

import re

import numpy as np

FIRST_FIELD = 16  # field numbers 16..2047 have two-byte tags
MAX_FIELDS = 2047 - FIRST_FIELD + 1
_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
_WIRE = {"double": 1, "sfixed32": 5, "bool": 0}
_SIZE = {"double": 8, "sfixed32": 4, "bool": 1}
LAYOUT = "fixed-v1"  # channel metadata value that marks this layout


def fits(names: list[str]) -> bool:
    """Can these field names be one fixed-layout message (identifiers, unique, not too many)?"""
    return len(names) <= MAX_FIELDS and len(set(names)) == len(names) and all(_IDENTIFIER.match(n) for n in names)


class FixedMessage:
    """Encoder and decoder of one instance's step message: t, then Reals, Integers, Booleans."""

    def __init__(self, name: str, reals: list[str], integers: list[str], booleans: list[str]) -> None:
        self.name = name
        self.fields = [("t", "double")] + [(n, "double") for n in reals] + [(n, "sfixed32") for n in integers] + \
                      [(n, "bool") for n in booleans]
        if not fits([n for n, _ in self.fields]):
            raise ValueError(f"{name}: output names do not fit a fixed-layout protobuf message")
        self.size = sum(2 + _SIZE[kind] for _, kind in self.fields)
        self._buf = np.zeros(self.size, dtype=np.uint8)
        offset = 0
        starts = {}
        for number, (_, kind) in enumerate(self.fields, start=FIRST_FIELD):
            tag = (number << 3) | _WIRE[kind]
            self._buf[offset], self._buf[offset + 1] = (tag & 0x7F) | 0x80, tag >> 7
            starts.setdefault(kind, offset + 2)
            offset += 2 + _SIZE[kind]
        self.n = {kind: sum(1 for _, k in self.fields if k == kind) for kind in _SIZE}
        self._views = {kind: self._view(self._buf, kind, starts.get(kind, 0)) for kind in _SIZE}
        self._starts = starts
        self._blank = self._buf.copy()  # the tags; encode_rows starts from it (it may run in another thread than encode)

    def _view(self, buf, kind: str, start: int) -> np.ndarray:
        dtype = {"double": "<f8", "sfixed32": "<i4", "bool": "u1"}[kind]
        return np.ndarray((self.n[kind],), dtype=dtype, buffer=buf, offset=start, strides=(2 + _SIZE[kind],))

    def encode(self, t: float, reals: np.ndarray, integers: np.ndarray, booleans: np.ndarray) -> bytes:
        d = self._views["double"]
        d[0] = t
        d[1:] = reals
        if self.n["sfixed32"]:
            self._views["sfixed32"][:] = integers
        if self.n["bool"]:
            self._views["bool"][:] = booleans != 0
        return self._buf.tobytes()

    def encode_rows(self, times: np.ndarray, reals: np.ndarray, integers: np.ndarray, booleans: np.ndarray) -> np.ndarray:
        """The messages of many steps at once: row i of the result is encode(times[i], reals[i], ...)."""
        n = len(times)
        buf = np.tile(self._blank, (n, 1))
        flat = buf.reshape(-1)
        d = self._rows(flat, n, "double")
        d[:, 0] = times
        d[:, 1:] = reals
        if self.n["sfixed32"]:
            self._rows(flat, n, "sfixed32")[:] = integers
        if self.n["bool"]:
            self._rows(flat, n, "bool")[:] = booleans != 0
        return buf

    def _rows(self, flat: np.ndarray, n: int, kind: str) -> np.ndarray:
        dtype = {"double": "<f8", "sfixed32": "<i4", "bool": "u1"}[kind]
        return np.ndarray((n, self.n[kind]), dtype=dtype, buffer=flat, offset=self._starts.get(kind, 0),
                          strides=(self.size, 2 + _SIZE[kind]))

    def decode_rows(self, data: bytes, n: int) -> dict:
        """n messages laid end to end: {field: its n values} (float64, int32 or bool arrays, copies)."""
        flat = np.frombuffer(data, dtype=np.uint8)
        if len(flat) != n * self.size:
            raise ValueError(f"{self.name}: {len(flat)} bytes are not {n} messages of {self.size}")
        values = {kind: self._rows(flat, n, kind) for kind in _SIZE}
        out, counters = {}, dict.fromkeys(_SIZE, 0)
        for name, kind in self.fields:
            out[name] = values[kind][:, counters[kind]].copy()
            counters[kind] += 1
        return out

    def decode(self, data: bytes) -> dict:
        buf = np.frombuffer(data, dtype=np.uint8)
        out = {}
        values = {kind: self._view(buf, kind, self._starts.get(kind, 0)) for kind in _SIZE}
        counters = dict.fromkeys(_SIZE, 0)
        for name, kind in self.fields:
            v = values[kind][counters[kind]]
            out[name] = float(v) if kind == "double" else int(v) if kind == "sfixed32" else bool(v)
            counters[kind] += 1
        return out

    def schema(self) -> bytes:
        """The FileDescriptorSet Foxglove and protobuf readers decode the message with."""
        from google.protobuf import descriptor_pb2 as d

        types = {"double": d.FieldDescriptorProto.TYPE_DOUBLE, "sfixed32": d.FieldDescriptorProto.TYPE_SFIXED32,
                 "bool": d.FieldDescriptorProto.TYPE_BOOL}
        message = d.DescriptorProto(name=self.message_type, field=[
            d.FieldDescriptorProto(name=name, number=number, type=types[kind], label=d.FieldDescriptorProto.LABEL_OPTIONAL)
            for number, (name, kind) in enumerate(self.fields, start=FIRST_FIELD)])
        file = d.FileDescriptorProto(name=f"tiltload/{self.message_type}.proto", package="tiltload", syntax="proto3",
                                     message_type=[message])
        return d.FileDescriptorSet(file=[file]).SerializeToString()

    @property
    def message_type(self) -> str:
        safe = re.sub(r"[^A-Za-z0-9_]", "_", self.name)
        return f"{safe[:1].upper()}{safe[1:]}Outputs"

    @property
    def full_name(self) -> str:
        return f"tiltload.{self.message_type}"

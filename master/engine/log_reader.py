"""Reading MCAP logs back: messages per topic decoded (fixed-layout protobuf or JSON), metadata, and logs without
their footer (a killed run) recovered by a streaming read up to their last complete chunk."""

from __future__ import annotations

import json
from pathlib import Path

from mcap.reader import make_reader

from .log_encoding import LAYOUT, FixedMessage


def _decoder(schema, channel):
    """A function bytes -> dict for one channel: JSON, or the fixed-layout protobuf (rebuilt from its schema)."""
    if channel.message_encoding == "json":
        return json.loads
    if channel.message_encoding == "protobuf" and channel.metadata.get("layout") == LAYOUT:
        from google.protobuf import descriptor_pb2 as d

        fds = d.FileDescriptorSet.FromString(schema.data)
        fields = fds.file[0].message_type[0].field
        kinds = {d.FieldDescriptorProto.TYPE_DOUBLE: "Real", d.FieldDescriptorProto.TYPE_SFIXED32: "Integer",
                 d.FieldDescriptorProto.TYPE_BOOL: "Boolean"}
        by = {"Real": [], "Integer": [], "Boolean": []}
        for f in fields[1:]:  # fields[0] is t
            by[kinds[f.type]].append(f.name)
        return FixedMessage(channel.topic.lstrip("/"), by["Real"], by["Integer"], by["Boolean"]).decode
    raise ValueError(f"{channel.topic}: cannot decode {channel.message_encoding} messages")


def read(path: Path, topics: list[str] | None = None) -> dict[str, list[dict]]:
    """Messages per topic, decoded (protobuf or JSON; non-finite JSON values come back as None), in log-time order.

    A log without its summary (a run killed mid-way) is read record by record up to its last complete
    chunk; `is_truncated(path)` tells whether that was needed."""
    return read_log(path, topics)[0]


def read_log(path: Path, topics: list[str] | None = None) -> tuple[dict[str, list[dict]], bool]:
    """(messages per topic, truncated): truncated is True for a log without footer, recovered by a streaming read."""
    out: dict[str, list[dict]] = {}
    decoders: dict[int, object] = {}
    try:
        with open(path, "rb") as f:
            for schema, channel, message in make_reader(f).iter_messages(topics=topics):
                decode = decoders.get(channel.id)
                if decode is None:
                    decode = decoders[channel.id] = _decoder(schema, channel)
                out.setdefault(channel.topic, []).append(decode(message.data))
        return out, False
    except Exception:  # no footer or summary: read what was written, record by record
        return _stream(path, topics), True


def _stream(path: Path, topics: list[str] | None) -> dict[str, list[dict]]:
    from mcap.records import Channel, Message, Schema
    from mcap.stream_reader import StreamReader

    schemas, channels, decoders, out = {}, {}, {}, {}
    with open(path, "rb") as f:
        try:
            for record in StreamReader(f).records:
                if isinstance(record, Schema):
                    schemas[record.id] = record
                elif isinstance(record, Channel):
                    channels[record.id] = record
                elif isinstance(record, Message):
                    channel = channels.get(record.channel_id)
                    if channel is None or (topics is not None and channel.topic not in topics):
                        continue
                    decode = decoders.get(channel.id)
                    if decode is None:
                        decode = decoders[channel.id] = _decoder(schemas.get(channel.schema_id), channel)
                    out.setdefault(channel.topic, []).append(decode(record.data))
        except Exception:  # the torn end of the file: everything before it is kept
            pass
    for msgs in out.values():
        msgs.sort(key=lambda m: m.get("t", 0.0))
    return out


def is_truncated(path: Path) -> bool:
    try:
        with open(path, "rb") as f:
            make_reader(f).get_summary()
            f.seek(-8, 2)
            return f.read(8) != b"\x89MCAP0\r\n"
    except Exception:
        return True


def read_metadata(path: Path) -> dict[str, dict]:
    """Metadata records by name ({} for a truncated log whose summary is lost)."""
    try:
        with open(path, "rb") as f:
            return {m.name: dict(m.metadata) for m in make_reader(f).iter_metadata()}
    except Exception:
        from mcap.records import Metadata
        from mcap.stream_reader import StreamReader

        found = {}
        with open(path, "rb") as f:
            try:
                for record in StreamReader(f).records:
                    if isinstance(record, Metadata):
                        found[record.name] = dict(record.metadata)
            except Exception:
                pass
        return found

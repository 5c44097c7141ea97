"""Reading MCAP logs back: messages per topic decoded (fixed-layout protobuf or JSON), metadata, and the log's state.

One streaming pass over the file, every chunk checked (its CRC, its decompression) before its messages are used:
- a complete log (footer and summary) reads whole;
- a torn log (a killed run: no footer) reads up to its last complete chunk;
- a damaged log (a chunk that fails its CRC or does not decompress, or broken framing before the end) reads up to
  the damage, and says so: `LogState.damage` names it, `intact_until` is the log time up to which it is intact.
`read` raises DamagedLog for a damaged log: no reader draws or scores the front of a damaged file as if it were
the whole (`read_checked` returns what is intact with the state, for a reader that reports it itself).
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

from ..errors import DescriptionError
from ..user_files import open_binary
from .encoding import LAYOUT, FixedMessage

MAGIC = b"\x89MCAP0\r\n"
NON_FINITE = ("inf", "-inf", "nan")  # how tiltload's JSON channels spell a value JSON cannot hold (faults/schedule.py)
MAX_CHUNK_BYTES = 64 * 2**20  # a chunk's declared size, uncompressed (tiltload writes 32-128 KiB; other tools' about 1-4 MiB)


class DamagedLog(DescriptionError):
    """A log whose bytes are damaged inside (not merely cut short); the message says where it stops being intact."""


class ForeignLog(DescriptionError):
    """A log another tool wrote, with a channel whose messages tiltload cannot read: the message names the channel and
    what tiltload expected there."""


def _json_decoder(topic: str, schema=None):
    """bytes -> dict for a JSON channel: an object whose "t", if any, is a number, and whose numeric fields (those its
    JSON schema types as numbers, and any that held a number in an earlier message) hold numbers or null in every
    message: text where a number goes names the channel and the field here, not in whichever reader meets it."""
    numeric = set()
    if schema is not None and schema.encoding == "jsonschema":
        try:
            properties = json.loads(schema.data).get("properties", {})
            numeric = {k for k, v in properties.items() if isinstance(v, dict) and v.get("type") in ("number", "integer")}
        except (ValueError, AttributeError, RecursionError):  # a schema that is not JSON: the messages still speak
            pass

    def decode(data: bytes) -> dict:
        try:
            msg = json.loads(data)
        except (ValueError, RecursionError) as err:  # ValueError: not UTF-8 or not JSON
            raise ForeignLog(f"channel {topic[:80]}: a message that is not JSON ({str(err)[:80]}); tiltload's JSON "
                             "channels hold one object per message") from None
        if not isinstance(msg, dict):
            raise ForeignLog(f"channel {topic[:80]}: a JSON {type(msg).__name__} where tiltload expects an object of "
                             "named values")
        t = msg.get("t", 0.0)
        if isinstance(t, bool) or not isinstance(t, (int, float)):
            raise ForeignLog(f"channel {topic[:80]}: its time t holds {str(t)[:40]!r} where a number of seconds goes")
        for key, value in msg.items():
            if value is None:  # null says no type: a fault's flag is null for most faults, a name for a dropout
                continue
            if isinstance(value, (int, float)):
                numeric.add(key)
            elif key in numeric and isinstance(value, str) and value not in NON_FINITE:
                # text where a number went (a fault's value may also be a list, [lo, hi], or a non-finite spelled out)
                raise ForeignLog(f"channel {topic[:80]}: field {key[:80]} holds {str(value)[:40]!r} where a number goes")
        return msg

    return decode


@dataclass(frozen=True)
class LogState:
    """What a pass over a log found."""

    torn: bool  # no footer: the file ends where a killed run stopped writing
    damage: str | None  # what is broken inside the file, if anything
    intact_until: float | None  # s: the last message time before the damage or the torn end (None: no message)
    duration: float | None  # s: the last message time the log's summary declares (None: no summary)

    @property
    def complete(self) -> bool:
        return not self.torn and self.damage is None

    def describe(self, path: Path) -> str:
        """One line for the user (empty for a complete log)."""
        upto = "no message is intact" if self.intact_until is None else f"intact up to t = {self.intact_until:.3f} s"
        if self.duration is not None and self.intact_until is not None:
            upto += f" of {self.duration:.3f} s"
        if self.damage is not None:
            return f"{path} is damaged ({self.damage}): {upto}"
        if self.torn:
            return f"{path} is truncated (no footer: a killed run): {upto}"
        return ""


def _decoder(schema, channel, raw: bool = False):
    """A function bytes -> dict for one channel: JSON, or the fixed-layout protobuf (rebuilt from its schema). raw: a
    fixed-layout channel's messages stay bytes (read_columns decodes them all at once), and this returns its layout."""
    if channel.message_encoding == "json":
        return _json_decoder(channel.topic, schema)
    if channel.message_encoding == "protobuf" and channel.metadata.get("layout") == LAYOUT and schema is not None:
        layout = _fixed_layout(schema, channel)
        return layout if raw else layout.decode
    what = (f"protobuf messages of schema {schema.name if schema is not None else '(none)'} without tiltload's fixed layout"
            if channel.message_encoding == "protobuf" else f"{channel.message_encoding or 'unnamed'}-encoded messages")
    raise ForeignLog(f"channel {channel.topic[:80]}: {what[:120]}; tiltload reads JSON channels and its own fixed-layout "
                     "protobuf (written by tiltload run)")


def _fixed_layout(schema, channel) -> FixedMessage:
    """The fixed layout a tiltload protobuf channel's schema declares (t, then doubles, sfixed32s and bools)."""
    from google.protobuf import descriptor_pb2 as d
    from google.protobuf.message import DecodeError

    kinds = {d.FieldDescriptorProto.TYPE_DOUBLE: "Real", d.FieldDescriptorProto.TYPE_SFIXED32: "Integer",
             d.FieldDescriptorProto.TYPE_BOOL: "Boolean"}
    try:
        fields = d.FileDescriptorSet.FromString(schema.data).file[0].message_type[0].field
    except (DecodeError, IndexError):
        fields = None
    if not fields or fields[0].name != "t" or any(f.type not in kinds for f in fields):
        raise ForeignLog(f"channel {channel.topic[:80]}: its schema {schema.name[:80]} claims tiltload's fixed layout but "
                         "is not one (a message of t, then double, sfixed32 and bool fields)")
    by = {"Real": [], "Integer": [], "Boolean": []}
    for f in fields[1:]:  # fields[0] is t
        by[kinds[f.type]].append(f.name)
    return FixedMessage(channel.topic.lstrip("/"), by["Real"], by["Integer"], by["Boolean"])


def _inflated(chunk):
    """The chunk with its records uncompressed, refused by its declared size before anything is decompressed, and
    decompressed no further than that size (a chunk that inflates beyond what it declares is damaged, not read)."""
    from dataclasses import replace

    if chunk.uncompressed_size > MAX_CHUNK_BYTES:
        raise _Refused(f"declares {chunk.uncompressed_size} bytes uncompressed, more than the {MAX_CHUNK_BYTES} a chunk "
                       "may have: refused unread")
    if chunk.compression == "":
        return chunk
    if chunk.compression == "zstd":
        import zstandard

        parts, left = [], chunk.uncompressed_size + 1  # one byte more than declared tells a chunk that inflates further
        with zstandard.ZstdDecompressor().stream_reader(chunk.data, read_across_frames=True) as reader:
            while left > 0 and (part := reader.read(left)):
                parts.append(part)
                left -= len(part)
        data = b"".join(parts)
    elif chunk.compression == "lz4":
        try:
            import lz4.frame
        except ImportError:
            raise _Refused("is lz4-compressed (tiltload writes zstd; pip install lz4 to read it)") from None
        data = lz4.frame.LZ4FrameDecompressor().decompress(chunk.data, max_length=chunk.uncompressed_size + 1)
    else:
        raise _Refused(f"uses the compression {chunk.compression[:40]!r} (MCAP's are zstd and lz4)")
    if len(data) != chunk.uncompressed_size:
        raise _Refused(f"inflates to {'more than ' if len(data) > chunk.uncompressed_size else ''}{len(data)} bytes, not "
                       f"the {chunk.uncompressed_size} it declares")
    return replace(chunk, compression="", data=data)


class _Refused(Exception):
    """A chunk not decompressed: why, for LogState.damage."""


@dataclass
class _Scan:
    messages: dict[str, list[dict]]
    metadata: dict[str, dict]
    state: LogState
    layouts: dict[str, FixedMessage] | None = None  # raw scans: the fixed-layout channels' layouts (their messages: bytes)


def _has_footer(f) -> bool:
    """The file ends with a footer record and the closing magic (what a finished writer leaves)."""
    size = f.seek(0, os.SEEK_END)
    if size < 2 * len(MAGIC) + 29:
        return False
    f.seek(size - len(MAGIC) - 29)  # footer: opcode, length, summary start, summary offset start, CRC = 1 + 8 + 20
    tail = f.read()
    f.seek(0)
    return tail[-len(MAGIC):] == MAGIC and tail[0] == 0x02


def _scan(path: Path, topics: list[str] | None, want_messages: bool = True, raw: bool = False) -> _Scan:
    from mcap.records import Channel, Chunk, DataEnd, Footer, Message, Metadata, Schema, Statistics
    from mcap.stream_reader import StreamReader, breakup_chunk, get_chunk_data_stream

    schemas, channels, decoders = {}, {}, {}
    layouts: dict[str, FixedMessage] = {}
    messages: dict[str, list[dict]] = {}
    metadata: dict[str, dict] = {}
    last_time = None  # ns
    damage, duration, data_ended, footer = None, None, False, False

    def take(record) -> None:
        nonlocal last_time
        if isinstance(record, Schema):
            schemas[record.id] = record
        elif isinstance(record, Channel):
            channels[record.id] = record
        elif isinstance(record, Message):
            last_time = record.log_time if last_time is None else max(last_time, record.log_time)
            channel = channels.get(record.channel_id)
            if not want_messages or channel is None or (topics is not None and channel.topic not in topics):
                return
            decode = decoders.get(channel.id)
            if decode is None:
                decode = decoders[channel.id] = _decoder(schemas.get(channel.schema_id), channel, raw)
                if isinstance(decode, FixedMessage):
                    layouts[channel.topic] = decode
                    decode = decoders[channel.id] = bytes
            messages.setdefault(channel.topic, []).append(decode(record.data))

    with open_binary(path, "log") as f:
        ends_well = _has_footer(f)
        records = StreamReader(f, emit_chunks=True, validate_crcs=True, record_size_limit=MAX_CHUNK_BYTES).records
        chunk_no = 0
        while True:
            try:
                record = next(records)
            except StopIteration:
                break
            except Exception as err:  # broken framing: the torn end of a killed run, or damage in a file with its end
                if ends_well:
                    damage = (f"its summary is unreadable ({_why(err)})" if data_ended
                              else f"unreadable record after chunk {chunk_no} ({_why(err)})")
                break
            if isinstance(record, Chunk):
                chunk_no += 1
                try:
                    record = _inflated(record)
                    if want_messages:
                        inner = breakup_chunk(record, validate_crc=True)
                    else:  # decompressed and its CRC checked, its records not parsed
                        get_chunk_data_stream(record, validate_crc=True)
                        inner = ()
                        last_time = record.message_end_time if last_time is None else max(last_time, record.message_end_time)
                except Exception as err:
                    damage = f"chunk {chunk_no}, from t = {record.message_start_time / 1e9:.3f} s, {_why(err)}"
                    break
                for r in inner:
                    take(r)
            elif isinstance(record, Metadata):
                if not data_ended:
                    metadata[record.name] = dict(record.metadata)
            elif isinstance(record, DataEnd):
                data_ended = True
            elif isinstance(record, Statistics):
                duration = record.message_end_time / 1e9 if record.message_count else None
            elif isinstance(record, Footer):
                footer = True
            else:
                take(record)
    if damage is None and ends_well and not footer:
        damage = "its end is unreadable"
    if damage is not None and ends_well and duration is None:
        duration = _declared_duration(path)
    for topic, msgs in messages.items():
        if topic not in layouts:
            msgs.sort(key=lambda m: m.get("t", 0.0))
    state = LogState(torn=not ends_well, damage=damage, intact_until=None if last_time is None else last_time / 1e9,
                     duration=duration)
    return _Scan(messages, metadata, state, layouts if raw else None)


def _declared_duration(path: Path) -> float | None:
    """The last message time the summary declares (a damaged log whose summary is intact says how long it was)."""
    from mcap.reader import make_reader

    try:
        with open_binary(path, "log") as f:
            stats = make_reader(f).get_summary().statistics
        return stats.message_end_time / 1e9 if stats is not None and stats.message_count else None
    except Exception:
        return None


def _why(err: Exception) -> str:
    from mcap.stream_reader import CRCValidationError

    if isinstance(err, CRCValidationError):
        return "fails its CRC check"
    if isinstance(err, _Refused):
        return str(err)
    text = str(err).strip() or type(err).__name__
    if type(err).__name__ == "ZstdError":
        return f"does not decompress: {text}"
    return f"{type(err).__name__}: {text}"[:160]


def read_checked(path: Path, topics: list[str] | None = None) -> tuple[dict[str, list[dict]], LogState]:
    """(messages per topic up to any damage or torn end, the log's state): for a reader that reports the state."""
    scan = _scan(Path(path), topics)
    return scan.messages, scan.state


def read_columns(path: Path, topics: list[str] | None = None) -> tuple[dict[str, tuple], LogState]:
    """({topic: (times, {field: values})}, the log's state): each channel's messages as columns in log-time order,
    the fixed-layout ones decoded all at once with numpy (a hundred times faster than a dict a message); JSON
    channels' numeric fields (null: NaN). A damaged log's columns end where it is intact (the state says)."""
    import numpy as np

    scan = _scan(Path(path), topics, raw=True)
    out: dict[str, tuple] = {}
    for topic, msgs in scan.messages.items():
        layout = scan.layouts.get(topic)
        if layout is not None:
            columns = layout.decode_rows(b"".join(msgs), len(msgs))
        else:
            msgs = [m for m in msgs if isinstance(m, dict) and "t" in m]
            keys = [k for k, v in (msgs[0].items() if msgs else ()) if v is None or isinstance(v, (bool, int, float))]
            columns = {k: _numbers(topic, k, [m.get(k) for m in msgs]) for k in keys}
        if "t" not in columns:
            continue
        order = np.argsort(columns["t"], kind="stable")
        times = columns.pop("t")[order]
        out[topic] = (times, {k: v[order] for k, v in columns.items()})
    return out, scan.state


def _numbers(topic: str, field: str, values: list):
    """A JSON channel's field as floats (null: NaN); text or a structure where a number goes names the channel."""
    import numpy as np

    for v in values:
        if v is not None and not isinstance(v, (bool, int, float)):
            raise ForeignLog(f"channel {topic[:80]}: field {field[:80]} holds {str(v)[:40]!r} where a number goes")
    return np.array([np.nan if v is None else float(v) for v in values])


def read(path: Path, topics: list[str] | None = None) -> dict[str, list[dict]]:
    """Messages per topic, decoded (protobuf or JSON; non-finite JSON values come back as None), in log-time order.

    A log without its footer (a run killed mid-way) is read up to its last complete chunk (`is_truncated` tells).
    A damaged log raises DamagedLog, naming the damage and the time up to which the log is intact."""
    messages, state = read_checked(path, topics)
    if state.damage is not None:
        raise DamagedLog(state.describe(Path(path)))
    return messages


def read_log(path: Path, topics: list[str] | None = None) -> tuple[dict[str, list[dict]], bool]:
    """(messages per topic, truncated): truncated is True for a log without footer. DamagedLog as read."""
    messages, state = read_checked(path, topics)
    if state.damage is not None:
        raise DamagedLog(state.describe(Path(path)))
    return messages, state.torn


def check(path: Path) -> LogState:
    """The log's state without decoding its messages (every chunk is still read and checked)."""
    return _scan(Path(path), None, want_messages=False).state


def is_truncated(path: Path) -> bool:
    try:
        with open_binary(path, "log") as f:
            return not _has_footer(f)
    except (OSError, ValueError):  # ValueError: UserFileError
        return True


def read_metadata(path: Path) -> dict[str, dict]:
    """Metadata records by name: through the summary's index when the log has its footer, else those a streaming
    read finds before the torn end or the damage. (Whether the messages are intact is check's job.)"""
    from mcap.reader import make_reader

    with open_binary(path, "log") as f:
        if _has_footer(f):
            try:
                return {m.name: dict(m.metadata) for m in make_reader(f).iter_metadata()}
            except Exception:  # a damaged summary: the records themselves may still read
                pass
    return _scan(Path(path), None, want_messages=False).metadata

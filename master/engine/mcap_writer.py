"""An MCAP writer for many messages at once: the loop's logs, written at the speed the tick loop runs.

Every record but Message is built by the mcap library's own record classes (header, schemas,
channels, metadata, chunks, indexes, statistics, summary, footer). Messages come in batches (one
call of the tick loop: hundreds of steps) and their records are laid out with numpy, the payloads
of a fixed-layout channel copied as one matrix. Chunks of about `chunk_size` bytes are compressed
(zstd, level 1) and written by a background thread, so compression runs beside the tick loop (the
kernel and zstd both release the GIL). A chunk is written whole or not at all: a killed run leaves
a file readable up to its last written chunk.

Why not foxglove-sdk's writer, which this replaced: one `Channel.log` call per message cost
about 4 times the tiltload loop's own tick on a 2-core machine (benchmarks/cosim.py measures both).
"""

from __future__ import annotations

import queue
import threading
import zlib
from pathlib import Path

import numpy as np
import zstandard
from mcap.data_stream import RecordBuilder
from mcap.records import (
    Channel,
    Chunk,
    ChunkIndex,
    DataEnd,
    Footer,
    Header,
    MessageIndex,
    Metadata,
    MetadataIndex,
    Schema,
    Statistics,
    SummaryOffset,
)

MAGIC = b"\x89MCAP0\r\n"
MESSAGE_OPCODE = 0x05
_MESSAGE_HEADER = np.dtype([("opcode", "u1"), ("length", "<u8"), ("channel", "<u2"), ("sequence", "<u4"),
                            ("log_time", "<u8"), ("publish_time", "<u8")])  # 31 bytes, packed (MCAP Message record)
CHUNK_SIZE = 32 * 1024


class MessageBatch:
    """Messages to write, each with an order key (written in key order; equal keys in the order added): single
    messages with their own payload, and runs of fixed-size messages whose payloads are the rows of one matrix."""

    def __init__(self) -> None:
        self.singles: list[tuple[int, int, int, bytes]] = []  # (key, channel, log time, payload)
        self.runs: list[tuple[np.ndarray, int, np.ndarray, np.ndarray]] = []  # (keys, channel, log times, payload rows)

    def add(self, channel: int, log_time: int, payload: bytes, key: int = 0) -> None:
        self.singles.append((key, channel, log_time, payload))

    def add_rows(self, channel: int, log_times: np.ndarray, payloads: np.ndarray, keys: np.ndarray) -> None:
        """len(keys) messages on one channel; payloads: a uint8 matrix, one message per row."""
        if len(keys):
            self.runs.append((np.asarray(keys, dtype=np.int64), channel, np.asarray(log_times, dtype=np.uint64), payloads))

    def __len__(self) -> int:
        return len(self.singles) + sum(len(r[0]) for r in self.runs)


class McapWriter:
    def __init__(self, path: Path, chunk_size: int = CHUNK_SIZE, library: str = "tiltload") -> None:
        self.path = Path(path)
        self._file = open(self.path, "wb")
        self.chunk_size = chunk_size
        self._schemas: list[Schema] = []
        self._channels: list[Channel] = []
        self._metadata_index: list[MetadataIndex] = []
        self._chunk_indexes: list[ChunkIndex] = []
        self._counts: dict[int, int] = {}
        self._sequence: dict[int, int] = {}
        self._messages = 0
        self._start = self._end = None
        self._pending = bytearray()  # message records of the chunk being filled
        self._pending_index: dict[int, list[tuple[int, int]]] = {}
        self._pending_times: list[tuple[int, int]] = []  # (first, last) log time of each part of the chunk
        self._compressor = zstandard.ZstdCompressor(level=1)
        self._queue: queue.Queue = queue.Queue(maxsize=64)
        self._error: BaseException | None = None
        self._thread = threading.Thread(target=self._drain, name="mcap-writer", daemon=True)
        self._thread.start()
        b = RecordBuilder()
        Header(profile="", library=library).write(b)
        self._put(MAGIC + b.end())

    # --- the writing thread: the only one that touches the file ------------------------------------------------------
    def _drain(self) -> None:
        while True:
            item = self._queue.get()
            if item is None:
                return
            if self._error is not None:
                continue
            try:
                item() if callable(item) else self._file.write(item)
            except BaseException as err:  # reported by the next call of the main thread
                self._error = err

    def _put(self, item) -> None:
        if self._error is not None:
            raise OSError(f"writing {self.path} failed: {self._error}")
        self._queue.put(item)

    # --- records -----------------------------------------------------------------------------------------------------
    def add_schema(self, name: str, encoding: str, data: bytes) -> int:
        schema = Schema(id=len(self._schemas) + 1, name=name, encoding=encoding, data=data)
        self._schemas.append(schema)
        b = RecordBuilder()
        schema.write(b)
        self._put(b.end())
        return schema.id

    def add_channel(self, topic: str, schema_id: int, message_encoding: str, metadata: dict[str, str] | None = None) -> int:
        channel = Channel(id=len(self._channels) + 1, schema_id=schema_id, topic=topic, message_encoding=message_encoding,
                          metadata=dict(metadata or {}))
        self._channels.append(channel)
        self._counts[channel.id] = 0
        self._sequence[channel.id] = 0
        b = RecordBuilder()
        channel.write(b)
        self._put(b.end())
        return channel.id

    def add_metadata(self, name: str, data: dict[str, str]) -> None:
        self._seal()  # a metadata record goes between chunks
        record = Metadata(name=name, metadata=dict(data))

        def write() -> None:
            b = RecordBuilder()
            record.write(b)
            raw = b.end()
            self._metadata_index.append(MetadataIndex(offset=self._file.tell(), length=len(raw), name=name))
            self._file.write(raw)
        self._put(write)

    def add_messages(self, batch: MessageBatch) -> None:
        """Append the messages to the chunks (in key order), sealing each chunk as it reaches the chunk size."""
        n = len(batch)
        if not n:
            return
        singles = batch.singles
        keys = np.concatenate([np.array([s[0] for s in singles], dtype=np.int64), *(r[0] for r in batch.runs)])
        channels = np.concatenate([np.array([s[1] for s in singles], dtype=np.uint16),
                                   *(np.full(len(r[0]), r[1], dtype=np.uint16) for r in batch.runs)])
        times = np.concatenate([np.array([s[2] for s in singles], dtype=np.uint64), *(r[2] for r in batch.runs)])
        lengths = np.concatenate([np.array([len(s[3]) for s in singles], dtype=np.int64),
                                  *(np.full(len(r[0]), r[3].shape[1], dtype=np.int64) for r in batch.runs)])
        order = np.argsort(keys, kind="stable")
        where = np.empty(n, dtype=np.int64)  # message (as added) -> its place in the file
        where[order] = np.arange(n)
        channels, times, lengths = channels[order], times[order], lengths[order]
        sequences = np.empty(n, dtype=np.uint32)
        for c in np.unique(channels):  # a counter per channel, as a publisher numbers its messages
            mine = channels == c
            count = int(np.count_nonzero(mine))
            start = self._sequence[int(c)]
            sequences[mine] = np.arange(start, start + count, dtype=np.uint32)
            self._sequence[int(c)] = start + count
            self._counts[int(c)] += count
        header = np.zeros(n, dtype=_MESSAGE_HEADER)
        header["opcode"] = MESSAGE_OPCODE
        header["length"] = 22 + lengths
        header["channel"], header["sequence"], header["log_time"], header["publish_time"] = channels, sequences, times, times
        width = _MESSAGE_HEADER.itemsize
        ends = np.cumsum(width + lengths)
        starts = ends - width - lengths
        blob = np.empty(int(ends[-1]), dtype=np.uint8)
        blob[(starts[:, None] + np.arange(width)).ravel()] = header.view(np.uint8)
        for i, (_, _, _, payload) in enumerate(singles):
            s = int(starts[where[i]]) + width
            blob[s:s + len(payload)] = np.frombuffer(payload, dtype=np.uint8)
        at = len(singles)
        for run_keys, _, _, rows in batch.runs:
            places = where[at:at + len(run_keys)]
            blob[(starts[places][:, None] + width + np.arange(rows.shape[1])).ravel()] = rows.ravel()
            at += len(run_keys)
        self._messages += n
        first, last = int(times.min()), int(times.max())
        self._start = first if self._start is None else min(self._start, first)
        self._end = last if self._end is None else max(self._end, last)
        self._put(lambda: self._append(blob, starts, ends, channels, times))  # chunking and indexes in the writing thread

    def _append(self, blob: np.ndarray, starts: np.ndarray, ends: np.ndarray, channels: np.ndarray, times: np.ndarray) -> None:
        """Message records (laid out in blob) into the chunk being filled, split at record boundaries (the writing
        thread only)."""
        n, at = len(starts), 0
        while at < n:
            room = self.chunk_size - len(self._pending)
            base = int(starts[at])
            stop = min(max(int(np.searchsorted(ends, base + max(room, 1), side="left")) + 1, at + 1), n)
            offset0 = len(self._pending)
            self._pending += blob[base:int(ends[stop - 1])].tobytes()
            part_channels, part_times = channels[at:stop], times[at:stop]
            part_offsets = starts[at:stop] - base + offset0
            for c in np.unique(part_channels):
                mine = part_channels == c
                self._pending_index.setdefault(int(c), []).extend(zip(part_times[mine].tolist(), part_offsets[mine].tolist()))
            self._pending_times.append((int(part_times.min()), int(part_times.max())))
            at = stop
            if len(self._pending) >= self.chunk_size:
                self._write_chunk()

    def _seal(self) -> None:
        """Seal the chunk being filled (in the writing thread, where the chunk is)."""
        self._put(self._write_chunk)

    def _write_chunk(self) -> None:
        """The chunk being filled, compressed, written with its message indexes (the writing thread only)."""
        if not self._pending:
            return
        data, index, times = bytes(self._pending), self._pending_index, self._pending_times
        self._pending, self._pending_index, self._pending_times = bytearray(), {}, []
        compressed = self._compressor.compress(data)
        chunk = Chunk(compression="zstd", data=compressed, message_start_time=min(t[0] for t in times),
                      message_end_time=max(t[1] for t in times),
                      uncompressed_crc=zlib.crc32(data), uncompressed_size=len(data))
        b = RecordBuilder()
        chunk.write(b)
        raw = b.end()
        start = self._file.tell()
        entry = ChunkIndex(message_start_time=chunk.message_start_time, message_end_time=chunk.message_end_time,
                           chunk_start_offset=start, chunk_length=len(raw), message_index_offsets={},
                           message_index_length=0, compression="zstd", compressed_size=len(compressed),
                           uncompressed_size=len(data))
        b = RecordBuilder()
        for channel, records in index.items():
            entry.message_index_offsets[channel] = start + len(raw) + b.count
            MessageIndex(channel_id=channel, records=records).write(b)
        indexes = b.end()
        entry.message_index_length = len(indexes)
        self._file.write(raw + indexes)
        self._chunk_indexes.append(entry)

    def flush(self) -> None:
        """Seal the chunk being filled and wait until everything so far is on disk."""
        self._seal()
        done = threading.Event()
        self._put(lambda: (self._file.flush(), done.set()))
        while not done.wait(0.1):
            if not self._thread.is_alive() or self._error is not None:
                break
        if self._error is not None:
            raise OSError(f"writing {self.path} failed: {self._error}")

    def close(self) -> None:
        """The last chunk, the summary section and the footer; then the file is complete."""
        self._seal()
        self._put(self._finish)
        self._queue.put(None)
        self._thread.join()
        self._file.close()
        if self._error is not None:
            raise OSError(f"writing {self.path} failed: {self._error}")

    def _finish(self) -> None:
        f = self._file
        b = RecordBuilder()
        DataEnd(data_section_crc=0).write(b)
        f.write(b.end())
        summary_start = f.tell()
        groups = []

        def group(records, opcode: int) -> None:
            if not records:
                return
            rb = RecordBuilder()
            for r in records:
                r.write(rb)
            raw = rb.end()
            groups.append(SummaryOffset(group_opcode=opcode, group_start=f.tell(), group_length=len(raw)))
            f.write(raw)
        group(self._schemas, 0x03)
        group(self._channels, 0x04)
        group([Statistics(message_count=self._messages, schema_count=len(self._schemas), channel_count=len(self._channels),
                          attachment_count=0, metadata_count=len(self._metadata_index), chunk_count=len(self._chunk_indexes),
                          message_start_time=self._start or 0, message_end_time=self._end or 0,
                          channel_message_counts={c: n for c, n in self._counts.items() if n})], 0x0B)
        group(self._chunk_indexes, 0x08)
        group(self._metadata_index, 0x0D)
        offsets_start = f.tell()
        rb = RecordBuilder()
        for g in groups:
            g.write(rb)
        Footer(summary_start=summary_start, summary_offset_start=offsets_start, summary_crc=0).write(rb)
        f.write(rb.end() + MAGIC)

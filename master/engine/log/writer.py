"""An MCAP writer for many messages at once: the loop's logs, written at the speed the tick loop runs.

Every record but Message and MessageIndex is built by the mcap library's own record classes (header,
schemas, channels, metadata, chunks, chunk indexes, statistics, summary, footer). Messages come in
batches (one call of the tick loop: hundreds of steps); their records, and each chunk's message
indexes, are laid out by the engine's C kernel (native/tl_mcap.c) in one call, byte for byte what the
library's classes would write (tests/engine/test_log.py checks them against each other). Chunks of about `chunk_size` bytes are compressed
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
    Metadata,
    MetadataIndex,
    Schema,
    Statistics,
    SummaryOffset,
)

from ..native.kernel import library

MAGIC = b"\x89MCAP0\r\n"
_MESSAGE_HEADER_SIZE = 31  # opcode, length, channel, sequence, log time, publish time (MCAP Message record)
_INDEX_HEADER_SIZE = 15  # opcode, length, channel, records length (MCAP MessageIndex record)
CHUNK_SIZE = 32 * 1024


class MessageBatch:
    """Messages to write, each with an order key (written in key order; equal keys in the order added): single
    messages with their own payload, and runs of messages on one channel whose payloads lie in one buffer (the rows
    of a matrix, or texts packed one after the other)."""

    def __init__(self) -> None:
        self.singles: list[tuple[int, int, int, bytes]] = []  # (key, channel, log time, payload)
        # (keys, channels, log times, buffer, starts, lengths): message j is buffer[starts[j]:starts[j] + lengths[j]]
        self.runs: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = []

    def add(self, channel: int, log_time: int, payload: bytes, key: int = 0) -> None:
        self.singles.append((key, channel, log_time, payload))

    def add_rows(self, channel: int, log_times: np.ndarray, payloads: np.ndarray, keys: np.ndarray) -> None:
        """len(keys) messages on one channel; payloads: a uint8 matrix, one message per row."""
        n, width = payloads.shape
        starts = np.arange(n, dtype=np.int64) * width
        self._run(keys, channel, log_times, np.ascontiguousarray(payloads).reshape(-1), starts, np.full(n, width, dtype=np.int64))

    def add_packed(self, channel: int, log_times: np.ndarray, data: np.ndarray, ends: np.ndarray, keys: np.ndarray) -> None:
        """Messages on one channel packed in data: message j is data[ends[j - 1]:ends[j]]; an empty one is left out."""
        ends = np.asarray(ends, dtype=np.int64)
        starts = np.concatenate(([0], ends[:-1]))
        keep = ends > starts
        self._run(np.asarray(keys)[keep], channel, np.asarray(log_times)[keep], data, starts[keep], (ends - starts)[keep])

    def _run(self, keys, channel: int, log_times, data: np.ndarray, starts: np.ndarray, lengths: np.ndarray) -> None:
        if len(keys):
            self.runs.append((np.asarray(keys, dtype=np.int64), np.full(len(keys), channel, dtype=np.uint16),
                              np.asarray(log_times, dtype=np.uint64), data, starts, lengths))

    def __len__(self) -> int:
        return len(self.singles) + sum(len(r[0]) for r in self.runs)

    def all_runs(self) -> list:
        """The runs, the single messages first as one run of their own (their payloads joined in one buffer)."""
        if not self.singles:
            return self.runs
        lengths = np.array([len(s[3]) for s in self.singles], dtype=np.int64)
        single = (np.array([s[0] for s in self.singles], dtype=np.int64), np.array([s[1] for s in self.singles], dtype=np.uint16),
                  np.array([s[2] for s in self.singles], dtype=np.uint64),
                  np.frombuffer(b"".join(s[3] for s in self.singles), dtype=np.uint8), np.cumsum(lengths) - lengths, lengths)
        return [single, *self.runs]


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
        self._chunk = _FillingChunk(chunk_size)  # message records of the chunk being filled, and their index
        self._compressor = zstandard.ZstdCompressor(level=1)
        self._queue: queue.Queue = queue.Queue(maxsize=64)
        # batches handed to the writing thread and not yet in the chunks: one at most, so a killed run loses at most the
        # chunk being filled and the last batch (not a backlog)
        # the last batch handed to the writing thread, set once laid out: set only after its put, so a signal raised
        # between two statements here (SIGTERM as KeyboardInterrupt) never leaves a wait for a batch that was not queued
        self._last_laid_out: threading.Event | None = None
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

    def add_messages(self, batch: MessageBatch, fill=(), wait: bool = True) -> None:
        """Append the messages to the chunks (in key order), sealing each chunk as it reaches the chunk size. fill:
        callables the writing thread runs first, each adding messages to the batch (encoding them beside the tick loop
        from copies of its values). Waits until the previous call's messages are in the chunks: the writer is at most
        one batch behind (wait=False: a last batch before closing, queued behind it without waiting)."""
        if not len(batch) and not fill:
            return
        if wait:
            self._wait_for_room()
        laid_out = threading.Event()
        self._put(lambda: self._lay_out(batch, fill, laid_out))
        self._last_laid_out = laid_out

    def _wait_for_room(self) -> None:
        previous = self._last_laid_out
        while previous is not None and not previous.wait(0.1):
            if self._error is not None or not self._thread.is_alive():
                break

    def _lay_out(self, batch: MessageBatch, fill, laid_out: threading.Event) -> None:
        """The batch's Message records in key order, into the chunks (the writing thread only)."""
        try:
            self._lay_out_records(batch, fill)
        finally:
            laid_out.set()

    def _lay_out_records(self, batch: MessageBatch, fill) -> None:
        for f in fill:
            f(batch)
        runs = batch.all_runs()
        if runs:
            keys, channels, times = (np.concatenate([r[i] for r in runs]) for i in range(3))
            lengths = np.concatenate([r[5] for r in runs])
            sources = np.concatenate([r[4] + (r[3].ctypes.data if len(r[3]) else 0) for r in runs])  # payload addresses
            order = np.argsort(keys, kind="stable")
            channels, times, lengths, sources = channels[order], times[order], lengths[order], sources[order]
            n = len(order)
            sequences = np.empty(n, dtype=np.uint32)
            for c in np.unique(channels):  # a counter per channel, as a publisher numbers its messages
                mine = channels == c
                count = int(np.count_nonzero(mine))
                start = self._sequence[int(c)]
                sequences[mine] = np.arange(start, start + count, dtype=np.uint32)
                self._sequence[int(c)] = start + count
                self._counts[int(c)] += count
            ends = np.cumsum(_MESSAGE_HEADER_SIZE + lengths)
            blob = np.empty(int(ends[-1]), dtype=np.uint8)
            library().tl_mcap_messages(n, _ptr(channels), _ptr(sequences), _ptr(times), _ptr(lengths), _ptr(sources), _ptr(blob))
            self._messages += n
            first, last = int(times.min()), int(times.max())
            self._start = first if self._start is None else min(self._start, first)
            self._end = last if self._end is None else max(self._end, last)
            self._append(blob, ends, channels, times)

    def _append(self, blob: np.ndarray, ends: np.ndarray, channels: np.ndarray, times: np.ndarray) -> None:
        """Message records (laid out in blob) into the chunk being filled, split at record boundaries, each chunk
        written as it reaches the chunk size (the writing thread only)."""
        at, n = 0, len(ends)
        batch = (n, _ptr(blob), _ptr(ends), _ptr(channels), _ptr(times))
        while at < n:
            at = self._chunk.fill(batch, ends, at)
            if self._chunk.size >= self.chunk_size:
                self._write_chunk()

    def _seal(self) -> None:
        """Seal the chunk being filled (in the writing thread, where the chunk is)."""
        self._put(self._write_chunk)

    def _write_chunk(self) -> None:
        """The chunk being filled, compressed, written with its message indexes (the writing thread only)."""
        if not self._chunk.size:
            return
        data, indexes, starts, first, last = self._chunk.take()
        compressed = self._compressor.compress(data)
        chunk = Chunk(compression="zstd", data=compressed, message_start_time=first, message_end_time=last,
                      uncompressed_crc=zlib.crc32(data), uncompressed_size=len(data))
        b = RecordBuilder()
        chunk.write(b)
        raw = b.end()
        start = self._file.tell()
        entry = ChunkIndex(message_start_time=chunk.message_start_time, message_end_time=chunk.message_end_time,
                           chunk_start_offset=start, chunk_length=len(raw), message_index_offsets={},
                           message_index_length=0, compression="zstd", compressed_size=len(compressed),
                           uncompressed_size=len(data))
        for channel, at in starts.items():
            entry.message_index_offsets[channel] = start + len(raw) + at
        entry.message_index_length = len(indexes)
        self._file.write(raw + indexes)
        self._file.flush()  # in the kernel's hands: a killed process loses nothing of it
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


class _FillingChunk:
    """The chunk being filled: its message records, and (channel, log time, offset) of each in the parts the writer
    appended, in arrays the kernel fills and reads in place (their addresses taken once: numpy's .ctypes costs
    microseconds a call)."""

    def __init__(self, chunk_size: int) -> None:
        self.chunk_size = chunk_size
        self.state = np.zeros(3, dtype=np.int64)  # bytes, messages, parts
        self.sizes = np.zeros(3, dtype=np.uint64)  # index bytes, first and last log time
        self._allocate(2 * chunk_size, chunk_size // _MESSAGE_HEADER_SIZE + 2)

    @property
    def size(self) -> int:
        return int(self.state[0])

    def _allocate(self, capacity: int, messages: int) -> None:
        """Room for capacity bytes and as many messages (and parts), what the chunk holds kept."""
        size, count, parts = (int(x) for x in self.state)

        def grown(name: str, dtype, length: int, keep: int):
            new = np.empty(length, dtype=dtype)
            old = getattr(self, name, None)
            if old is not None:
                new[:keep] = old[:keep]
            return new
        self.data = grown("data", np.uint8, capacity, size)
        self.channel = grown("channel", np.uint16, messages, count)
        self.time = grown("time", np.uint64, messages, count)
        self.offset = grown("offset", np.uint64, messages, count)
        self.part_ends = grown("part_ends", np.int64, messages, parts)
        self.order, self.at = np.empty(messages, dtype=np.uint16), np.empty(messages, dtype=np.int64)
        self.out = np.empty((_INDEX_HEADER_SIZE + 16) * messages, dtype=np.uint8)
        self._ptrs = [_ptr(a) for a in (self.data, self.state, self.channel, self.time, self.offset, self.part_ends, self.order,
                                        self.at, self.out, self.sizes)]

    def fill(self, batch: tuple, ends: np.ndarray, at: int) -> int:
        """Records at, at + 1, ... of a batch's records into the chunk until it reaches the chunk size; the next record to
        take. batch: (records, and the addresses of their bytes, ends, channels, log times)."""
        n, blob, batch_ends, channels, times = batch
        data, state, c, t, o, e = self._ptrs[:6]
        lib = library()
        while True:
            next_at = lib.tl_mcap_fill(n, at, blob, batch_ends, channels, times, self.chunk_size, data, len(self.data), state,
                                       c, t, o, e, len(self.channel))
            if next_at >= 0:
                return next_at
            record = int(ends[at] - (ends[at - 1] if at else 0))  # no room: a large record, or many small ones
            self._allocate(max(2 * len(self.data), self.size + record + self.chunk_size), 2 * len(self.channel))
            data, state, c, t, o, e = self._ptrs[:6]

    def take(self) -> tuple[bytes, bytes, dict[int, int], int, int]:
        """The chunk's message records, its MessageIndex records, where each channel's starts in them, its first and
        last log time; then the chunk is empty."""
        _, _, c, t, o, e, order, at, out, sizes = self._ptrs
        size, count, parts = (int(x) for x in self.state)
        channels = library().tl_mcap_message_indexes(count, c, t, o, parts, e, order, at, out, sizes)
        index_size, first, last = (int(x) for x in self.sizes)
        self.state[:] = 0
        return (self.data[:size].tobytes(), self.out[:index_size].tobytes(),
                dict(zip(self.order[:channels].tolist(), self.at[:channels].tolist())), first, last)


def _ptr(array: np.ndarray) -> int:
    return array.ctypes.data

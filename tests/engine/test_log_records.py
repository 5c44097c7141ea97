"""The log's records laid out in C (native/tl_mcap.c) against an independent reference: the mcap library's reader and
record classes."""

from __future__ import annotations

import io
import struct

import numpy as np
import zstandard
from mcap.data_stream import RecordBuilder
from mcap.reader import make_reader
from mcap.records import Chunk, ChunkIndex, Message, MessageIndex, Statistics
from mcap.stream_reader import StreamReader
from tiltload.master.engine.log.encoding import FixedMessage
from tiltload.master.engine.log.writer import McapWriter, MessageBatch


def random_batches(rng, channels: list[int], count: int):
    """Batches of messages of every kind the logger adds (single, matrix rows, packed texts with empty ones left out),
    with their order keys, and the messages each should write, in order: (channel, log time, payload)."""
    batches = []
    for _ in range(count):
        batch, expected = MessageBatch(), []
        for key in rng.permutation(40):
            kind, channel, t = rng.integers(3), int(rng.choice(channels)), int(rng.integers(0, 10**12))
            if kind == 0:
                payload = rng.bytes(int(rng.choice([0, 5, 3000])))  # empty, small, larger than the test's chunk
                batch.add(channel, t, payload, int(4 * key))
                expected.append((4 * key, 0, channel, t, payload))
            elif kind == 1:
                rows = rng.integers(0, 256, (3, 17), dtype=np.uint8)
                keys = 4 * key + 1 + np.arange(3) * 1000
                times = rng.integers(0, 10**12, 3).astype(np.uint64)
                batch.add_rows(channel, times, rows, keys)
                expected += [(int(k), 1, channel, int(tt), r.tobytes()) for k, tt, r in zip(keys, times, rows)]
            else:
                texts = [b"", b"{\"a\": 1}", b"", b"x" * int(rng.integers(1, 90))]
                data = np.frombuffer(b"".join(texts), dtype=np.uint8)
                ends = np.cumsum([len(x) for x in texts])
                keys = 4 * key + 2 + np.arange(4) * 1000
                times = rng.integers(0, 10**12, 4).astype(np.uint64)
                batch.add_packed(channel, times, data, ends, keys)
                expected += [(int(k), 2, channel, int(tt), x) for k, tt, x in zip(keys, times, texts) if x]
        expected.sort(key=lambda e: e[0])  # stable: equal keys keep the order they were added in
        batches.append((batch, [(c, t, p) for _, _, c, t, p in expected]))
    return batches


def test_the_writer_s_records_are_what_the_mcap_library_reads_and_writes(tmp_path):
    rng = np.random.default_rng(7)
    path = tmp_path / "w.mcap"
    writer = McapWriter(path, chunk_size=1024)  # many chunks, some cut by a message larger than a chunk
    schema = writer.add_schema("s", "jsonschema", b"{}")
    channels = [writer.add_channel(f"/c{i}", schema, "json") for i in range(5)]
    expected = []
    for batch, messages in random_batches(rng, channels, 6):
        writer.add_messages(batch)
        expected += messages
    writer.close()

    # every message, in order, numbered per channel as a publisher would, read by the library (CRCs checked)
    records = list(StreamReader(open(path, "rb"), validate_crcs=True).records)
    messages = [r for r in records if isinstance(r, Message)]
    assert [(m.channel_id, m.log_time, m.publish_time, m.data) for m in messages] == [(c, t, t, p) for c, t, p in expected]
    numbers: dict[int, int] = {}
    for m in messages:
        assert m.sequence == numbers.get(m.channel_id, 0)
        numbers[m.channel_id] = m.sequence + 1
    with open(path, "rb") as f:  # the summary's indexes lead the seeking reader to the same messages
        summary_read = [(c.id, m.log_time, m.data) for _, c, m in make_reader(f).iter_messages(log_time_order=False)]
    assert summary_read == [(c, t, p) for c, t, p in expected]
    statistics = next(r for r in records if isinstance(r, Statistics))
    assert statistics.message_count == len(expected)
    assert statistics.channel_message_counts == {c: n for c, n in numbers.items()}

    # each chunk's message indexes: byte for byte what the library's MessageIndex writes for the chunk's messages, at
    # the offsets the chunk index gives, and each entry pointing at its message in the chunk
    raw = path.read_bytes()
    chunk_indexes = [r for r in records if isinstance(r, ChunkIndex)]
    assert len(chunk_indexes) > 10
    for entry in chunk_indexes:
        chunk = next(r for r in StreamReader(io.BytesIO(raw[entry.chunk_start_offset:]), skip_magic=True, emit_chunks=True).records)
        assert isinstance(chunk, Chunk)
        data = zstandard.ZstdDecompressor().decompress(chunk.data, max_output_size=chunk.uncompressed_size)
        inside, at = {}, 0
        while at < len(data):  # Message records (MCAP specification: opcode, length, channel, sequence, times, data)
            opcode, length, channel, _, log_time = struct.unpack_from("<BQHIQ", data, at)
            assert opcode == 0x05
            inside.setdefault(channel, []).append((log_time, at))
            at += 9 + length
        assert sorted(entry.message_index_offsets) == sorted(inside)
        for channel, offset in entry.message_index_offsets.items():
            b = RecordBuilder()
            MessageIndex(channel_id=channel, records=inside[channel]).write(b)
            library_bytes = b.end()
            assert raw[offset:offset + len(library_bytes)] == library_bytes
        assert chunk.message_start_time == min(t for v in inside.values() for t, _ in v)
        assert chunk.message_end_time == max(t for v in inside.values() for t, _ in v)


def test_fixed_layout_rows_of_a_batch_are_the_single_step_encoding():
    rng = np.random.default_rng(5)
    enc = FixedMessage("sensors", [f"r{i}" for i in range(30)], ["count", "mode"], ["valid", "stale", "held"])
    n = 500
    times = rng.random(n) * 40
    reals = rng.standard_normal((n, 30)) * 10.0 ** rng.integers(-300, 300, (n, 30))
    reals[rng.random((n, 30)) < 0.05] = np.nan
    reals[rng.random((n, 30)) < 0.02] = -np.inf
    integers = rng.integers(-2**31, 2**31, (n, 2)).astype(np.int32)
    booleans = rng.integers(0, 3, (n, 3)).astype(np.int32)  # any non-zero fmi2Boolean is true
    rows = enc.encode_rows(times, reals, integers, booleans)
    for i in range(n):
        assert rows[i].tobytes() == enc.encode(times[i], reals[i], integers[i], booleans[i])
    empty = np.zeros((3, 0))
    assert FixedMessage("none", [], [], []).encode_rows(times[:3], empty, empty, empty).shape == (3, 10)  # t: tag, double

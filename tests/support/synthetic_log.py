"""MCAP logs of known signals, written with the engine's writer (as a run writes them): a check's expected verdicts are
then computed from the signals themselves."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from tiltload.master.engine.log.encoding import LAYOUT, FixedMessage
from tiltload.master.engine.log.writer import McapWriter, MessageBatch


def write_log(path: Path, channels: dict[str, tuple[np.ndarray, dict[str, np.ndarray]]], stop_time: float | None = None,
              finish: bool = True) -> Path:
    """channels: instance -> (message times, {Real output: values}). finish=False leaves no footer (a killed run)."""
    w = McapWriter(Path(path))
    w.add_metadata("run", {"stop_time": str(stop_time)} if stop_time is not None else {"library": "test"})
    batch = MessageBatch()
    for name, (times, values) in channels.items():
        enc = FixedMessage(name, list(values), [], [])
        schema = w.add_schema(enc.full_name, "protobuf", enc.schema())
        channel = w.add_channel(f"/{name}", schema, "protobuf", {"layout": LAYOUT})
        rows = np.column_stack([np.asarray(v, dtype=float) for v in values.values()])
        for k, t in enumerate(times):
            batch.add(channel, int(round(t * 1e9)), enc.encode(float(t), rows[k], np.zeros(0, np.int32), np.zeros(0, bool)))
    w.add_messages(batch)
    if finish:
        w.close()
    else:
        w.flush()
    return Path(path)

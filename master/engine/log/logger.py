"""MCAP logging (docs/master.md, "Logs"): one channel per FMU instance, log time = simulation time in ns.

Every output of every instance is logged after each of its steps at the time it belongs to (and once at t = 0 after
initialization, or at the closing samples: edges.py), or every n-th of those with `log_every`. Instance channels are
protobuf messages of a fixed layout (log/encoding.py: the encoding measured cheapest, about 2 us a message, and NaN
needs no special case); an instance whose output names are not identifiers, or with outputs of other types than
Float64, Int32 and Boolean (FMI 3.0's Float32, Int8..UInt64, an Enumeration of either standard), gets a JSON channel
whose schema gives each output its type (integer with its type's range, an Enumeration's items by name). Derived channels,
which the application supplies (DerivedChannel: tiltload's 3D scene of the UAV, thrusters, rod and
load), are JSON messages computed from one instance's outputs. The writer (log/writer.py) takes
each call of the tick loop's messages at once and compresses beside the loop; the file is finalized
on any exit path, so an interrupted run leaves a readable log up to its last step, and a killed one
up to its last chunk. The readers are in log/reader.py.
"""

from __future__ import annotations

import base64
import json
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import edges
from ..fmi.model_description import FMI_TYPES, enumeration_items, fmi_type
from ..observers import Observer
from . import provenance
from .encoding import LAYOUT, FixedMessage, fits
from .writer import McapWriter, MessageBatch

# Chunks of a run in batches: a killed run loses at most the chunk being filled (128 KiB: about 50 ticks of the loop,
# 0.6 s) and the batch in the writer's hands (256 ticks), and the writer's cost per chunk is spread over 50 ticks.
CHUNK = 128 * 1024
# Chunks of a run tick by tick (a per-step observer, or paced on the real-time clock): the batch is a tick (or 0.25 s),
# so the chunk bounds the loss, 32 KiB: about 13 ticks, 0.16 s.
CHUNK_TICK_BY_TICK = 32 * 1024


def _clean(x: float):
    return x if math.isfinite(x) else None


KERNEL_TYPES = ("Float64", "Int32", "Boolean")  # the types a fixed-layout message holds (double, sfixed32, bool)


def _json_type(v) -> dict:
    """An output's JSON schema: its FMI type, an integer type's range, an Enumeration's items, a Binary's bytes."""
    name = fmi_type(v)
    kind = FMI_TYPES[name]
    if name == "String":
        return {"type": "string"}
    if name == "Binary":
        return {"type": "string", "contentEncoding": "base64", "description": "Binary"}
    if name == "Boolean":
        return {"type": "boolean"}
    if name == "Enumeration":
        return {"type": "integer", "description": f"Enumeration {getattr(v.declaredType, 'name', '')}".strip(),
                "oneOf": [{"const": value, "title": item} for item, value in enumeration_items(v)]}
    if kind.bounds is None:
        return {"type": "number", "description": name}
    return {"type": "integer", "description": name, "minimum": kind.bounds[0], "maximum": kind.bounds[1]}


def _converter(v):
    """How a carried value becomes its JSON value: whole numbers as integers, non-finite numbers as null."""
    name = fmi_type(v)
    if name == "Boolean":
        return bool
    return int if FMI_TYPES[name].bounds is not None else _clean


@dataclass(frozen=True)
class DerivedChannel:
    """A JSON channel computed from one instance's Real outputs on every `every`-th logged step of it.

    encoder(names) is called once, at the start, with the instance's Real output names; it returns
    encode(values, log time in ns) -> JSON text, or None for a step with nothing to log, where values is
    the instance's Real outputs in that order (a float64 array; read it, do not keep it).

    rows_encoder(names), if given, returns encode_rows(values, log times in ns) -> (data, ends) for many steps at once
    (values: one row per step, a float64 matrix; message j is data[ends[j - 1]:ends[j]], empty for nothing to log):
    the same messages as encode, byte for byte, at the cost of one call a batch."""

    topic: str
    source: str  # the instance
    schema_name: str
    schema: dict  # JSON schema of the messages
    encoder: Callable[[list[str]], Callable[[np.ndarray, int], str | None]]
    every: int = 1
    rows_encoder: Callable[[list[str]], Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]] | None = None


class McapLogger(Observer):
    threaded = True  # its writer encodes, compresses and writes beside the loop
    is_log = True  # the profile's "log" share is its calls (profile.py)

    def __init__(self, path: Path, metadata: dict | None = None, log_every: int = 1, derived=(), chunk_size: int | None = None) -> None:
        """chunk_size: bytes of the log's chunks; by default CHUNK, or CHUNK_TICK_BY_TICK when a per-step observer makes
        the loop run tick by tick."""
        if not (isinstance(log_every, int) and log_every >= 1):
            raise ValueError(f"log_every must be a whole number of steps >= 1, got {log_every!r}")
        self.path = Path(path)
        self.log_every = log_every
        self.final_metadata: dict[str, dict] = {}  # records written at finish (the run's metrics, for `tiltload compare`)
        self.derived = tuple(derived)
        self.metadata = metadata or {}
        self.chunk_size = chunk_size
        # called as hook(logger, error) when the run ends, before the log closes: an observer that writes what it
        # concluded (the requirements' channel and verdicts) with add_json_channel and final_metadata
        self.closing: list[Callable] = []
        self._writer: McapWriter | None = None

    def start(self, execution) -> None:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        # written under a temporary name: an earlier log of the same name is replaced only when this one is closed
        # (complete, or partial after an error or an interrupt); a killed run leaves <name>.partial beside it
        self.partial = self.path.with_name(self.path.name + ".partial")
        chunk = self.chunk_size or (CHUNK_TICK_BY_TICK if execution.stepwise_observers() else CHUNK)
        self._writer = w = McapWriter(self.partial, chunk)
        w.add_metadata("run", {k: str(v) for k, v in self.metadata.items()} or {"library": "tiltload"})
        # what ran (each FMU's digest, its parameters) and the outputs' units: a baseline says what changed from them
        w.add_metadata("fmus", provenance.fmus_record(execution.system.instances, execution.model_descriptions))
        w.add_metadata("units", provenance.units_record(execution.system.instances, execution.model_descriptions))
        self._channels, self._encoders, self._steps = {}, {}, {}
        self._outputs = {name: {t: [(v.name, _converter(v)) for v in vs] for t, vs in inst.outputs.items()}
                         for name, inst in execution.instances.items()}
        for name, inst in execution.instances.items():
            names = {t: [v.name for v in inst.outputs[t]] for t in ("Real", "Integer", "Boolean")}
            meta = {"fmu": str(inst.path)}
            standard = all(fmi_type(v) in KERNEL_TYPES for t in ("Real", "Integer", "Boolean") for v in inst.outputs[t]) \
                and not inst.text_outputs
            if standard and fits(["t", *names["Real"], *names["Integer"], *names["Boolean"]]):
                enc = FixedMessage(name, names["Real"], names["Integer"], names["Boolean"])
                schema = w.add_schema(enc.full_name, "protobuf", enc.schema())
                self._channels[name] = w.add_channel(f"/{name}", schema, "protobuf", {**meta, "layout": LAYOUT})
                self._encoders[name] = enc
            else:
                props = {"t": {"type": "number"}, **{v.name: _json_type(v) for t in ("Real", "Integer", "Boolean")
                                                       for v in inst.outputs[t]},
                         **{v.name: _json_type(v) for v in inst.text_outputs}}
                self._channels[name] = self._json_channel(f"/{name}", {"type": "object", "title": f"{name} outputs",
                                                                        "properties": props}, meta)
            self._steps[name] = 0
        self._derived: dict[str, list] = {}  # source instance -> [(channel, encode, every)]
        for d in self.derived:
            names = [v.name for v in execution.instances[d.source].outputs["Real"]]
            channel = self._json_channel(d.topic, d.schema, {}, d.schema_name)
            rows = d.rows_encoder(names) if d.rows_encoder is not None else None
            self._derived.setdefault(d.source, []).append((channel, d.encoder(names), d.every * self.log_every, rows))
        self._faults_channel = None
        if execution.system.faults:
            self._faults_channel = self._json_channel("/faults", {"type": "object", "title": "fault events", "properties": {
                "t": {"type": "number"}, "event": {"type": "string"}, "name": {"type": "string"}, "action": {"type": "string"},
                "targets": {"type": "array"}, "value": {}, "start": {"type": "number"}, "end": {}}}, {})
        self._batch = MessageBatch()
        timing = {i.name: i.timing for i in execution.system.instances}
        if execution.resumed_at is None:  # the outputs after initialization, of the instances whose sample at 0 they are
            for name, inst in execution.instances.items():
                if edges.logs_initial(timing[name]):
                    self.on_step(inst, execution.system.start_time)
        else:  # a run continued from a snapshot logs from where it goes on, in the cadence of the uninterrupted run
            for name in self._steps:
                self._steps[name] = edges.messages_before(timing[name], execution.ticks_done, execution.every[name])
        self._flush_batch()

    def _json_channel(self, topic: str, schema: dict, metadata: dict, name: str | None = None) -> int:
        schema_id = self._writer.add_schema(name or schema.get("title", ""), "jsonschema", json.dumps(schema).encode())
        return self._writer.add_channel(topic, schema_id, "json", metadata)

    def _flush_batch(self, fill=()) -> None:
        batch, self._batch = self._batch, MessageBatch()
        self._writer.add_messages(batch, fill)

    def add_rows_channel(self, topic: str, name: str, columns: list[str], times: np.ndarray, values: np.ndarray,
                         metadata: dict | None = None) -> None:
        """A channel of fixed-layout messages (t, then one double a column), one a row of values, written at once (from
        a closing hook). columns: identifiers."""
        enc = FixedMessage(name, list(columns), [], [])
        schema = self._writer.add_schema(enc.full_name, "protobuf", enc.schema())
        channel = self._writer.add_channel(topic, schema, "protobuf", {**(metadata or {}), "layout": LAYOUT})
        times = np.asarray(times, dtype=float)
        if len(times):  # encoded by the writer's thread, queued without waiting for it (the run is over: no backlog grows)
            values = np.asarray(values, dtype=float).reshape(len(times), len(columns))
            ns, keys = np.rint(times * 1e9).astype(np.uint64), np.arange(len(times), dtype=np.int64)
            none = np.zeros((len(times), 0), np.int32), np.zeros((len(times), 0), bool)
            self._writer.add_messages(MessageBatch(), [_fixed_rows(channel, enc, times, ns, values, *none, keys)], wait=False)

    def on_fault(self, t, fault, what) -> None:
        from ..faults.schedule import describe

        if self._faults_channel is not None:
            self._batch.add(self._faults_channel, int(round(t * 1e9)), json.dumps({"t": t, "event": what, **describe(fault)}).encode())

    def on_step(self, instance, t) -> None:
        v = instance.values
        self._write(instance.name, t, v["Real"], v["Integer"], v["Boolean"], instance.texts)

    def _write(self, name: str, t: float, reals, integers, booleans, texts=None) -> None:
        """One step of one instance (the values at t = 0): its message and its derived channels' messages."""
        k = self._steps[name]
        self._steps[name] = k + 1
        if k % self.log_every:
            return
        ns = int(round(t * 1e9))
        enc = self._encoders.get(name)
        payload = enc.encode(t, reals, integers, booleans) if enc is not None else \
            self._json(name, t, reals, integers, booleans, texts)
        self._batch.add(self._channels[name], ns, payload)
        for channel, encode, every, _ in self._derived.get(name, ()):
            if k % every == 0:
                text = encode(reals, ns)
                if text is not None:
                    self._batch.add(channel, ns, text.encode())

    def on_batch(self, execution, batch) -> None:
        """Every step of the batch in its order, fault events in their places. A message's order key is 4 p + 1 for
        record p (its derived messages 4 p + 2, fault events before it 4 p), as the steps happened. The fixed-layout
        and the batch-encoded derived messages are encoded by the writer's thread from copies of the logged rows,
        beside the next call of the tick loop; the others here."""
        out, fill = self._batch, []
        for name in batch.names:
            mine = batch.positions(name)
            if not len(mine):
                continue
            rows = batch.rows[name]
            k = self._steps[name] + np.arange(len(mine))
            self._steps[name] += len(mine)
            logged = np.flatnonzero(k % self.log_every == 0)
            if not len(logged):
                continue
            times = batch.time[mine][logged]
            ns = np.rint(times * 1e9).astype(np.uint64)
            keys = 4 * mine[logged] + 1
            reals = rows["Real"][logged]  # a copy: the loop's record rows are refilled by its next call
            enc = self._encoders.get(name)
            if enc is not None:
                fill.append(_fixed_rows(self._channels[name], enc, times, ns, reals, rows["Integer"][logged],
                                        rows["Boolean"][logged], keys))
            else:
                texts = batch.texts.get(name, {})
                for j, r in enumerate(logged.tolist()):
                    out.add(self._channels[name], int(ns[j]), self._json(name, float(times[j]), rows["Real"][r],
                                                                           rows["Integer"][r], rows["Boolean"][r],
                                                                           texts.get(r)), int(keys[j]))
            for channel, encode, every, encode_rows in self._derived.get(name, ()):
                picked = np.flatnonzero(k[logged] % every == 0)
                if encode_rows is not None:
                    fill.append(_packed_rows(channel, encode_rows, reals[picked], ns[picked], keys[picked] + 1))
                    continue
                for j in picked.tolist():
                    text = encode(reals[j], int(ns[j]))
                    if text is not None:
                        out.add(channel, int(ns[j]), text.encode(), int(keys[j]) + 1)
        if self._faults_channel is not None:
            from ..faults.schedule import describe

            for position, t, fault, what in batch.events:
                out.add(self._faults_channel, int(round(t * 1e9)), json.dumps({"t": t, "event": what, **describe(fault)}).encode(),
                        4 * position)
        self._flush_batch(fill)

    def _json(self, name: str, t: float, reals, integers, booleans, texts=None) -> bytes:
        """A JSON message (for outputs whose names are not identifiers, or of other types than the fixed layout's). JSON
        has no NaN: non-finite values are null; a Binary value is base64."""
        outputs = self._outputs[name]
        msg = {"t": t}
        for typ, values in (("Real", reals), ("Integer", integers), ("Boolean", booleans)):
            msg.update({n: convert(x) for (n, convert), x in zip(outputs[typ], values.tolist())})
        for n, x in (texts or {}).items():
            msg[n] = base64.b64encode(x).decode() if isinstance(x, bytes) else x
        return json.dumps(msg).encode()

    def snapshot_state(self) -> dict:
        return {"steps": dict(self._steps)}  # where each instance is in log_every and the derived channels' cadence

    def restore_state(self, state: dict) -> None:
        self._steps.update(state["steps"])

    def finish(self, execution, error) -> None:
        if self._writer is None:
            return
        self._flush_batch()
        for hook in self.closing:
            try:
                hook(self, error)
            except Exception as err:  # the log is closed whatever an observer's conclusion does
                self._writer.add_metadata("closing_error", {"message": f"{type(err).__name__}: {err}"[:300]})
        if error:
            self._writer.add_metadata("error", {"message": error})
        for name, record in self.final_metadata.items():
            self._writer.add_metadata(name, {k: repr(v) if isinstance(v, float) else str(v) for k, v in record.items()})
        self._writer.close()
        self._writer = None
        self.partial.replace(self.path)


def _fixed_rows(channel: int, enc: FixedMessage, times, ns, reals, integers, booleans, keys):
    """The writer's job of encoding one instance's fixed-layout messages of a batch."""
    return lambda batch: batch.add_rows(channel, ns, enc.encode_rows(times, reals, integers, booleans), keys)


def _packed_rows(channel: int, encode_rows, reals, ns, keys):
    """The writer's job of encoding a derived channel's messages of a batch (one call of its rows encoder)."""
    def job(batch: MessageBatch) -> None:
        if len(ns):
            data, ends = encode_rows(reals, ns)
            batch.add_packed(channel, ns, data, ends, keys)
    return job

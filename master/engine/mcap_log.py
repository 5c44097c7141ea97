"""MCAP logging (docs/master.md, "Logs"): one channel per FMU instance, log time = simulation time in ns.

Every output of every instance is logged after each of its steps (and once at t = 0), or after
every n-th step with `log_every`. Instance channels are protobuf messages of a fixed layout
(log_encoding.py: the encoding measured cheapest, about 2 us a message, and NaN needs no special
case); an instance whose output names are not identifiers gets a JSON channel. Derived channels,
which the application supplies (DerivedChannel: tiltload's 3D scene of the UAV, thrusters, rod and
load), are JSON messages computed from one instance's outputs. The writer is foxglove-sdk's
(Rust); the file is finalized on any exit path, so an interrupted run leaves a readable log up to
its last step. The readers are in log_reader.py.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from .log_encoding import LAYOUT, FixedMessage, fits
from .observers import Observer

CHUNK = 32 * 1024  # a killed run loses at most one chunk: about 12 ticks (0.15 s) of the loop


def _clean(x: float):
    return x if math.isfinite(x) else None


@dataclass(frozen=True)
class DerivedChannel:
    """A JSON channel computed from one instance's Real outputs on every `every`-th logged step of it.

    encoder(names) is called once, at the start, with the instance's Real output names; it returns
    encode(values {name: float or None for a non-finite value}, log time in ns) -> JSON text, or None
    for a step with nothing to log."""

    topic: str
    source: str  # the instance
    schema_name: str
    schema: dict  # JSON schema of the messages
    encoder: Callable[[list[str]], Callable[[dict, int], str | None]]
    every: int = 1


class McapLogger(Observer):
    def __init__(self, path: Path, metadata: dict | None = None, log_every: int = 1, derived=()) -> None:
        if not (isinstance(log_every, int) and log_every >= 1):
            raise ValueError(f"log_every must be a whole number of steps >= 1, got {log_every!r}")
        self.path = Path(path)
        self.log_every = log_every
        self.final_metadata: dict[str, dict] = {}  # records written at finish (the run's metrics, for `tiltload compare`)
        self.derived = tuple(derived)
        self.metadata = metadata or {}
        self._writer = None

    def start(self, execution) -> None:
        import foxglove
        from foxglove.mcap import MCAPCompression, MCAPWriteOptions

        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._context = foxglove.Context()  # this log's own channels, apart from any other run in the process
        options = MCAPWriteOptions(compression=MCAPCompression.Zstd, chunk_size=CHUNK, compression_threads=0)
        # written under a temporary name: an earlier log of the same name is replaced only when this one is closed
        # (complete, or partial after an error or an interrupt); a killed run leaves <name>.partial beside it
        self.partial = self.path.with_name(self.path.name + ".partial")
        self._writer = foxglove.open_mcap(str(self.partial), allow_overwrite=True, context=self._context, writer_options=options)
        self._writer.write_metadata("run", {k: str(v) for k, v in self.metadata.items()} or {"library": "tiltload"})
        self._channels, self._encoders, self._steps = {}, {}, {}
        self._outputs = {name: inst.outputs for name, inst in execution.instances.items()}
        for name, inst in execution.instances.items():
            names = {t: [v.name for v in inst.outputs[t]] for t in ("Real", "Integer", "Boolean")}
            meta = {"fmu": str(inst.path)}
            if fits(["t", *names["Real"], *names["Integer"], *names["Boolean"]]):
                enc = FixedMessage(name, names["Real"], names["Integer"], names["Boolean"])
                schema = foxglove.Schema(name=enc.full_name, encoding="protobuf", data=enc.schema())
                self._channels[name] = foxglove.Channel(f"/{name}", schema=schema, message_encoding="protobuf",
                                                        context=self._context, metadata={**meta, "layout": LAYOUT})
                self._encoders[name] = enc
            else:
                props = {n: {"type": "number" if t == "Real" else "integer" if t == "Integer" else "boolean"}
                         for t in ("Real", "Integer", "Boolean") for n in names[t]}
                self._channels[name] = foxglove.Channel(f"/{name}", schema={"type": "object", "title": f"{name} outputs",
                                                                             "properties": props},
                                                        context=self._context, metadata=meta)
            self._steps[name] = 0
        self._derived: dict[str, list] = {}  # source instance -> [(channel, output names, encode, every)]
        for d in self.derived:
            names = [v.name for v in execution.instances[d.source].outputs["Real"]]
            channel = foxglove.Channel(d.topic, schema=foxglove.Schema(name=d.schema_name, encoding="jsonschema",
                                                                       data=json.dumps(d.schema).encode()),
                                       message_encoding="json", context=self._context)
            self._derived.setdefault(d.source, []).append((channel, names, d.encoder(names), d.every * self.log_every))
        self._faults_channel = None
        if execution.system.faults:
            self._faults_channel = foxglove.Channel("/faults", schema={"type": "object", "title": "fault events", "properties": {
                "t": {"type": "number"}, "event": {"type": "string"}, "name": {"type": "string"}, "action": {"type": "string"},
                "targets": {"type": "array"}, "value": {}, "start": {"type": "number"}, "end": {}}}, context=self._context)
        for inst in execution.instances.values():
            self.on_step(inst, 0.0)

    def on_fault(self, t, fault, what) -> None:
        from .manipulators import describe

        if self._faults_channel is not None:
            self._faults_channel.log(json.dumps({"t": t, "event": what, **describe(fault)}), log_time=int(round(t * 1e9)))

    def on_step(self, instance, t) -> None:
        v = instance.values
        self._write(instance.name, t, v["Real"], v["Integer"], v["Boolean"])

    def _write(self, name: str, t: float, reals, integers, booleans, encoded: bytes | None = None) -> None:
        """One step of one instance: its message (encoded already, or now), and its derived channels' messages."""
        k = self._steps[name]
        self._steps[name] = k + 1
        if k % self.log_every:
            return
        ns = int(round(t * 1e9))
        enc = self._encoders.get(name)
        if enc is not None:
            self._channels[name].log(encoded if encoded is not None else enc.encode(t, reals, integers, booleans), log_time=ns)
        else:  # JSON has no NaN: non-finite values are written as null
            outputs = self._outputs[name]
            msg = {"t": t, **{v.name: _clean(x) for v, x in zip(outputs["Real"], reals.tolist())}}
            msg.update({v.name: int(x) for v, x in zip(outputs["Integer"], integers.tolist())})
            msg.update({v.name: bool(x) for v, x in zip(outputs["Boolean"], booleans.tolist())})
            self._channels[name].log(json.dumps(msg), log_time=ns)
        for channel, names, encode, every in self._derived.get(name, ()):
            if k % every == 0:
                text = encode({n: _clean(x) for n, x in zip(names, reals.tolist())}, ns)
                if text is not None:
                    channel.log(text, log_time=ns)

    def on_batch(self, execution, batch) -> None:
        """Every step of the batch in its order, fault events in their places; the fixed-layout messages of each
        instance are encoded at once."""
        encoded = {}
        for name, rows in batch.rows.items():
            enc = self._encoders.get(name)
            if enc is not None and len(rows["Real"]) + len(rows["Integer"]) + len(rows["Boolean"]):
                mine = batch.positions(name)
                encoded[name] = enc.encode_rows(batch.time[mine], rows["Real"], rows["Integer"], rows["Boolean"])
        events = batch.events
        e = 0
        names, instance, times, row = batch.names, batch.instance.tolist(), batch.time.tolist(), batch.row.tolist()
        for p in range(len(instance)):
            while e < len(events) and events[e][0] <= p:
                self.on_fault(*events[e][1:])
                e += 1
            name, r = names[instance[p]], row[p]
            rows = batch.rows[name]
            matrix = encoded.get(name)
            self._write(name, times[p], rows["Real"][r], rows["Integer"][r], rows["Boolean"][r],
                        matrix[r].tobytes() if matrix is not None else None)
        for event in events[e:]:
            self.on_fault(*event[1:])

    def finish(self, execution, error) -> None:
        if self._writer is None:
            return
        if error:
            self._writer.write_metadata("error", {"message": error})
        for name, record in self.final_metadata.items():
            self._writer.write_metadata(name, {k: repr(v) if isinstance(v, float) else str(v) for k, v in record.items()})
        self._writer.close()
        self._writer = None
        self.partial.replace(self.path)

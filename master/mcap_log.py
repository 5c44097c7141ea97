"""MCAP logging (DESIGN §7): one JSON channel per FMU instance, log time = simulation time in ns.

Every connected-or-not output of every instance is logged after each of its steps (and once at
t = 0), non-finite values as null. A foxglove.SceneUpdate channel replays the UAV, thrusters,
rod and load in 3D. Chunks are small and the file is finalized on any exit path, so an
interrupted run leaves a readable log up to its last step.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer

from . import scene
from .observers import Observer

CHUNK = 64 * 1024


def _clean(x: float):
    return x if math.isfinite(x) else None


class McapLogger(Observer):
    def __init__(self, path: Path, scene_from: str | None = None, metadata: dict | None = None, scene_every: int = 4) -> None:
        self.path = Path(path)
        self.scene_every = scene_every  # 3D scene on every 4th step of its instance: 21 Hz at the 12 ms tick
        self._scene_count = 0
        self._templates: dict[str, str] = {}
        self.final_metadata: dict[str, dict] = {}  # records written at finish (the run's metrics, for `tiltload compare`)
        self.scene_from = scene_from
        self.metadata = metadata or {}
        self._f = None

    def start(self, execution) -> None:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._f = open(self.path, "wb")
        try:
            compression = CompressionType.ZSTD
            import zstandard  # noqa: F401
        except ImportError:
            compression = CompressionType.NONE
        self._w = Writer(self._f, chunk_size=CHUNK, compression=compression)
        self._w.start(profile="", library="tiltload")
        self._w.add_metadata("run", {k: str(v) for k, v in self.metadata.items()})
        self._channels = {}
        for name, inst in execution.instances.items():
            props = {v.name: {"type": "number" if v.type == "Real" else "integer" if v.type == "Integer" else "boolean"}
                     for t in ("Real", "Integer", "Boolean") for v in inst.outputs[t]}
            schema = {"type": "object", "title": f"{name} outputs", "properties": props}
            sid = self._w.register_schema(name=f"tiltload.{name}", encoding="jsonschema", data=json.dumps(schema).encode())
            self._channels[name] = self._w.register_channel(topic=f"/{name}", message_encoding="json", schema_id=sid,
                                                            metadata={"fmu": str(inst.path)})
        if self.scene_from:
            sid = self._w.register_schema(name="foxglove.SceneUpdate", encoding="jsonschema", data=json.dumps(scene.SCHEMA).encode())
            self._scene_channel = self._w.register_channel(topic="/scene", message_encoding="json", schema_id=sid)
        for inst in execution.instances.values():
            self.on_step(inst, 0.0)

    def _template(self, instance) -> str:
        """One %-format template per instance: formatting a step's message is a single C-level operation."""
        tpl = self._templates.get(instance.name)
        if tpl is None:
            fields = ['"t":%.17g'] + [json.dumps(v.name) + ":%.17g" for v in instance.outputs["Real"]]
            fields += [json.dumps(v.name) + ":%d" for v in instance.outputs["Integer"]]
            fields += [json.dumps(v.name) + ":%s" for v in instance.outputs["Boolean"]]
            tpl = self._templates[instance.name] = "{" + ",".join(fields) + "}"
        return tpl

    def on_step(self, instance, t) -> None:
        values = instance.values
        reals = values["Real"].tolist()
        flags = ["true" if x else "false" for x in values["Boolean"].tolist()]
        if np.isfinite(values["Real"]).all():
            text = self._template(instance) % (t, *reals, *[int(x) for x in values["Integer"].tolist()], *flags)
        else:  # JSON has no NaN: non-finite values are written as null
            msg = {"t": t, **{v.name: _clean(x) for v, x in zip(instance.outputs["Real"], reals)}}
            msg.update({v.name: int(x) for v, x in zip(instance.outputs["Integer"], values["Integer"].tolist())})
            msg.update({v.name: x == "true" for v, x in zip(instance.outputs["Boolean"], flags)})
            text = json.dumps(msg)
        ns = int(round(t * 1e9))
        self._w.add_message(self._channels[instance.name], log_time=ns, publish_time=ns, data=text.encode())
        if self.scene_from == instance.name:
            self._scene_count += 1
            if (self._scene_count - 1) % self.scene_every == 0:
                names = [v.name for v in instance.outputs["Real"]]
                update = scene.scene_update({n: _clean(x) for n, x in zip(names, reals)}, ns)
                if update is not None:
                    self._w.add_message(self._scene_channel, log_time=ns, publish_time=ns, data=json.dumps(update).encode())

    def finish(self, execution, error) -> None:
        if self._f is None:
            return
        if error:
            self._w.add_metadata("error", {"message": error})
        for name, record in self.final_metadata.items():
            self._w.add_metadata(name, {k: repr(v) if isinstance(v, float) else str(v) for k, v in record.items()})
        self._w.finish()
        self._f.close()
        self._f = None


def read(path: Path, topics: list[str] | None = None) -> dict[str, list[dict]]:
    """Messages per topic, decoded from JSON, in log-time order."""
    out: dict[str, list[dict]] = {}
    with open(path, "rb") as f:
        for _schema, channel, message in make_reader(f).iter_messages(topics=topics):
            out.setdefault(channel.topic, []).append(json.loads(message.data))
    return out


def read_metadata(path: Path) -> dict[str, dict]:
    with open(path, "rb") as f:
        return {m.name: dict(m.metadata) for m in make_reader(f).iter_metadata()}

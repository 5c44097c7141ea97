"""A foxglove.SceneUpdate of the UAV body, its thrusters, the rod and the load, from the plant's outputs.

Poses come from the plant's own outputs (load position, UAV position and Euler angles), so
the 3D replay shows exactly what was simulated. Geometry: the thruster centres d_C2, d_C3 of
Table 5.1; sizes are only for display.
"""

from __future__ import annotations

import ctypes
import json
import math
import re
from functools import cache
from pathlib import Path

import numpy as np

from ....plant_fmu.parameters import MODEL_PARAMETERS
from ...engine.log.logger import DerivedChannel

_P = {s.name: s.default for s in MODEL_PARAMETERS}
THRUSTERS = [(_P[f"d_C{i}_x"], _P[f"d_C{i}_y"], _P[f"d_C{i}_z"]) for i in (2, 3)]

_VEC3 = {"type": "object", "properties": {k: {"type": "number"} for k in "xyz"}}
_POSE = {"type": "object", "properties": {"position": _VEC3, "orientation": {"type": "object"}}}
_TIME = {"type": "object", "properties": {"sec": {"type": "integer"}, "nsec": {"type": "integer"}}}
SCHEMA = {
    "title": "foxglove.SceneUpdate",
    "type": "object",
    "properties": {
        "deletions": {"type": "array", "items": {"type": "object"}},
        "entities": {"type": "array", "items": {"type": "object", "properties": {
            "timestamp": _TIME, "frame_id": {"type": "string"}, "id": {"type": "string"}, "lifetime": _TIME,
            "frame_locked": {"type": "boolean"}, "cubes": {"type": "array"}, "spheres": {"type": "array"},
            "lines": {"type": "array"}, "metadata": {"type": "array"}}}},
    },
}


def quaternion_zyx(phi: float, theta: float, psi: float) -> dict:
    cr, sr = math.cos(phi / 2), math.sin(phi / 2)
    cp, sp = math.cos(theta / 2), math.sin(theta / 2)
    cy, sy = math.cos(psi / 2), math.sin(psi / 2)
    return {"x": sr * cp * cy - cr * sp * sy, "y": cr * sp * cy + sr * cp * sy,
            "z": cr * cp * sy - sr * sp * cy, "w": cr * cp * cy + sr * sp * sy}


def _rotate(q: dict, v: tuple) -> tuple:
    x, y, z, w = q["x"], q["y"], q["z"], q["w"]
    vx, vy, vz = v
    tx, ty, tz = 2 * (y * vz - z * vy), 2 * (z * vx - x * vz), 2 * (x * vy - y * vx)
    return (vx + w * tx + y * tz - z * ty, vy + w * ty + z * tx - x * tz, vz + w * tz + x * ty - y * tx)


POSE_KEYS = ("x", "y", "z", "x_B", "y_B", "z_B", "phi_B", "theta_B", "psi_B")


def _vec(v) -> dict:
    return {"x": v[0], "y": v[1], "z": v[2]}


def _entity(stamp: tuple, body: tuple, q: dict, thrusters: list[tuple], load: tuple | None, entity: str = "tiltload") -> dict:
    """The scene's structure; the numbers (or placeholders) come in. load None: the UAV alone (no rod, no load)."""
    cubes = [{"pose": {"position": _vec(body), "orientation": q}, "size": {"x": 0.12, "y": 0.45, "z": 0.06},
              "color": {"r": 0.2, "g": 0.4, "b": 0.9, "a": 1.0}}]
    for centre in thrusters:
        cubes.append({"pose": {"position": _vec(centre), "orientation": q}, "size": {"x": 0.05, "y": 0.05, "z": 0.08},
                      "color": {"r": 0.9, "g": 0.5, "b": 0.1, "a": 1.0}})
    return {"deletions": [], "entities": [{
        "timestamp": {"sec": stamp[0], "nsec": stamp[1]}, "frame_id": "world", "id": entity, "lifetime": {"sec": 0, "nsec": 0},
        "frame_locked": False, "metadata": [],
        "cubes": cubes,
        "spheres": [] if load is None else [
            {"pose": {"position": _vec(load), "orientation": {"x": 0, "y": 0, "z": 0, "w": 1}},
             "size": {"x": 0.06, "y": 0.06, "z": 0.06}, "color": {"r": 0.9, "g": 0.1, "b": 0.1, "a": 1.0}}],
        "lines": [] if load is None else [
            {"type": 0, "pose": {"position": {"x": 0, "y": 0, "z": 0}, "orientation": {"x": 0, "y": 0, "z": 0, "w": 1}},
             "thickness": 0.01, "scale_invariant": False, "points": [_vec(load), _vec(body)],
             "color": {"r": 0.8, "g": 0.8, "b": 0.8, "a": 1.0}, "colors": [], "indices": []}],
    }]}


def _numbers(plant: dict, ns: int):
    q = quaternion_zyx(plant["phi_B"], plant["theta_B"], plant["psi_B"])
    body = (plant["x_B"], plant["y_B"], plant["z_B"])
    thrusters = []
    for d in THRUSTERS:
        off = _rotate(q, d)
        thrusters.append((body[0] + off[0], body[1] + off[1], body[2] + off[2]))
    return (ns // 1_000_000_000, ns % 1_000_000_000), body, q, thrusters, (plant["x"], plant["y"], plant["z"])


class SceneEncoder:
    """The same message as JSON text from a template built once: one %-format a message, ~6x faster than json.dumps;
    and the messages of many steps in one call of scene.c (encode_rows), byte for byte the same."""

    def __init__(self, with_load: bool = True, entity: str = "tiltload") -> None:
        self.with_load = with_load
        slots = iter(range(10_000))
        mark = lambda: f"\x00{next(slots)}\x00"  # noqa: E731
        stamp = (mark(), mark())
        body = (mark(), mark(), mark())
        q = {"x": mark(), "y": mark(), "z": mark(), "w": mark()}
        thrusters = [(mark(), mark(), mark()) for _ in THRUSTERS]
        load = (mark(), mark(), mark())
        text = json.dumps(_entity(stamp, body, q, thrusters, load if with_load else None, entity))
        parts = re.split(_SLOT, text)  # literal, slot, literal, ..., literal
        self._pieces, self._order = parts[0::2], [int(m) for m in parts[1::2]]
        self._template = "%s".join(piece.replace("%", "%%") for piece in self._pieces) % tuple(
            "%d" if k < 2 else "%.17g" for k in self._order)
        self._native = None

    def encode(self, plant: dict, ns: int) -> str | None:
        """The message for the plant's outputs by name (None for a non-finite pose: nothing sensible to draw)."""
        if any(plant.get(k) is None or not math.isfinite(plant[k]) for k in POSE_KEYS):
            return None
        stamp, body, q, thrusters, load = _numbers(plant, ns)
        flat = [*stamp, *body, q["x"], q["y"], q["z"], q["w"], *(c for t in thrusters for c in t), *(load if self.with_load else ())]
        return self._template % tuple(flat[i] for i in self._order)

    def encode_rows(self, values: np.ndarray, index: list[int], ns: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The messages of many steps: values (one row of the plant's Real outputs per step; its pose at index, in the
        order of POSE_KEYS), log times ns. Returns (data, ends): message j is data[ends[j - 1]:ends[j]], as encode() writes
        it; empty where encode() gives None."""
        if self._native is None:
            self._native = _NativeScene(self)
        return self._native.encode(values, index, ns)


_SLOT = r'"\\u0000(\d+)\\u0000"'  # a number's place in the JSON text of the structure


class _NativeScene:
    """SceneEncoder's template handed to scene.c once; then each call encodes a whole batch."""

    def __init__(self, scene: SceneEncoder) -> None:
        self.lib = scene_library()
        text = "".join(scene._pieces).encode()
        self.text = ctypes.create_string_buffer(text, len(text))
        self.piece_ends = np.cumsum([len(p.encode()) for p in scene._pieces]).astype(np.int64)
        self.order = np.array(scene._order, dtype=np.int32)
        self.thrusters = np.array(THRUSTERS, dtype=np.float64).reshape(-1)
        self.with_load = int(scene.with_load)
        self.room = len(text) + 32 * len(self.order)  # bytes a message can take at most

    def encode(self, values: np.ndarray, index: list[int], ns: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        values = np.ascontiguousarray(values, dtype=np.float64)
        ns = np.ascontiguousarray(ns, dtype=np.uint64)
        n = len(ns)
        keys = np.array(index, dtype=np.int32)
        out = np.empty(max(n * self.room, 1), dtype=np.uint8)
        ends = np.zeros(n, dtype=np.int64)
        status = self.lib.tl_scene_encode(n, values.ctypes.data, values.shape[1] if values.ndim == 2 else 0, keys.ctypes.data,
                                          ns.ctypes.data, len(THRUSTERS), self.thrusters.ctypes.data, self.with_load,
                                          self.text, self.piece_ends.ctypes.data, len(self.order), self.order.ctypes.data,
                                          out.ctypes.data, len(out), ends.ctypes.data)
        if status != 0:
            raise RuntimeError("scene.c: a message did not fit its room")
        return out[:int(ends[-1]) if n else 0], ends


@cache
def scene_library():
    """scene.c, compiled like the engine's kernel (libm's sin and cos, not the compiler's: the Python encoder's)."""
    from ...engine.native.kernel import CFLAGS, compiled

    lib = compiled("tl_scene", (Path(__file__).with_name("scene.c"),), (*CFLAGS, "-fno-builtin-sin", "-fno-builtin-cos"), ("m",))
    p, n, i = ctypes.c_void_p, ctypes.c_int64, ctypes.c_int
    lib.tl_scene_encode.argtypes = [n, p, n, p, p, i, p, i, ctypes.c_char_p, p, i, p, p, n, p]
    lib.tl_scene_encode.restype = i
    lib.tl_scene_g17.argtypes = [ctypes.c_double, ctypes.c_char_p]
    lib.tl_scene_g17.restype = i
    return lib


SCENE_EVERY = 4  # a scene on every 4th logged step of the plant: 21 Hz at the 12 ms tick


def scene_channels(sources: str | tuple[str, ...] = "plant") -> list[DerivedChannel]:
    """The 3D scene of one vehicle on /scene, or of several (a formation) on /scene/<instance>, as log channels.
    A plant without the rod's joint angles (the UAV alone) is drawn without rod and load."""
    sources = (sources,) if isinstance(sources, str) else tuple(sources)

    def encoder(names: list[str], entity: str):
        scene = SceneEncoder(with_load="gamma_1" in names, entity=entity)
        index = [names.index(k) for k in POSE_KEYS]

        def encode(values, ns: int) -> str | None:  # values: the plant's Real outputs
            return scene.encode(dict(zip(POSE_KEYS, values[index].tolist())), ns)

        def encode_rows(values: np.ndarray, ns: np.ndarray) -> tuple[np.ndarray, np.ndarray]:  # many steps at once
            return scene.encode_rows(values, index, ns)
        return encode, encode_rows

    def channel(source: str) -> DerivedChannel:
        entity = source if len(sources) > 1 else "tiltload"
        return DerivedChannel("/scene" if len(sources) == 1 else f"/scene/{source}", source, "foxglove.SceneUpdate", SCHEMA,
                              lambda names: encoder(names, entity)[0], SCENE_EVERY, lambda names: encoder(names, entity)[1])
    return [channel(s) for s in sources]

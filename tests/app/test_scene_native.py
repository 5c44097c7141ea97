"""The 3D scene encoded in C (app/loop/scene.c) against the Python scene encoder, and its number printing against Python's
own '%.17g' (David Gay's correctly rounded conversion)."""

from __future__ import annotations

import ctypes
import json
import math

import numpy as np
import pytest
from tiltload.master.app.loop.scene import POSE_KEYS, SceneEncoder, scene_library


def poses(rng, n: int) -> np.ndarray:
    """Rows of a plant's Real outputs (the pose among other columns) over magnitudes from 1e-20 to 1e20, a few zero,
    non-finite or negative zero."""
    rows = rng.standard_normal((n, 12)) * 10.0 ** rng.integers(-20, 21, (n, 12))
    rows[rng.random((n, 12)) < 0.02] = 0.0
    rows[rng.random((n, 12)) < 0.01] = -0.0
    rows[rng.random((n, 12)) < 0.005] = np.nan
    rows[rng.random((n, 12)) < 0.005] = -np.inf
    return rows


@pytest.mark.parametrize("with_load", [True, False])
def test_the_c_scene_is_the_python_scene_byte_for_byte(with_load):
    rng = np.random.default_rng(3)
    rows = poses(rng, 3000)
    index = [11, 0, 3, 1, 2, 5, 4, 7, 9]  # the pose's columns, in the order of POSE_KEYS
    ns = rng.integers(0, 10**13, len(rows)).astype(np.uint64)
    scene = SceneEncoder(with_load=with_load, entity="uav")
    data, ends = scene.encode_rows(rows, index, ns)
    starts = np.concatenate(([0], ends[:-1]))
    skipped = 0
    for row, t, a, b in zip(rows, ns.tolist(), starts, ends):
        python = scene.encode(dict(zip(POSE_KEYS, row[index].tolist())), t)
        skipped += python is None
        assert data[a:b].tobytes() == (b"" if python is None else python.encode())
    assert 0 < skipped < len(rows)  # both kinds of step were tried
    assert json.loads(data[starts[0]:ends[0]].tobytes() or data[starts[1]:ends[1]].tobytes())["entities"][0]["id"] == "uav"


def test_the_scene_prints_numbers_as_printf_g17():
    lib, out = scene_library(), ctypes.create_string_buffer(40)
    rng = np.random.default_rng(11)
    values = list(rng.standard_normal(50_000) * 10.0 ** rng.integers(-20, 21, 50_000))
    values += [v for v in np.frombuffer(rng.integers(0, 2**63, 50_000, dtype=np.int64).tobytes()) if math.isfinite(v)]
    for k in range(-16, 18):  # powers of ten, and the doubles either side of values that round at the 17th digit
        for x in (10.0**k, 1.5 * 10.0**k, 9.999999999999999 * 10.0**k, 1.0000000000000005 * 10.0**k):
            values += [x, -x, float(np.nextafter(x, 0)), float(np.nextafter(x, math.inf))]
    values += [0.0, -0.0, 5e-324, 1.7976931348623157e308, 2.0**-50, 99999999999999999.0, 9999999999999999.0]
    differ = [(x, out.raw[:n]) for x in values if (n := lib.tl_scene_g17(x, out)) and out.raw[:n] != (b"%.17g" % x)]
    assert not differ

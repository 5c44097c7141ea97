"""On-disk cache of designs: an LMI synthesis takes tens of seconds (SDPA), so it runs once.

The key covers everything the gain depends on: the kind, T_c, the plant parameters, the
sources of the design and model code, and the versions of the solver stack. A changed input
means a new key, never a stale design.
"""

from __future__ import annotations

import hashlib
import os
from importlib import metadata
from pathlib import Path

import numpy as np

from ...native_fmu.cache import cache_root
from . import artifact
from .artifact import Design

__all__ = ["cache_root"]  # the machine's cache (native_fmu.cache), where designs and FMUs are kept

_HERE, _PLANT = Path(__file__).parent, Path(__file__).parents[2] / "plant_fmu"
# the code a gain depends on: the design modules and the model they linearize (not the FMU run-time code)
_CODE = [_HERE / f for f in ("error_dynamics.py", "weights.py", "dlqr.py", "lmi.py", "lmi_check.py", "problems.py", "synthesize.py",
                              "artifact.py", "control_law.py")] + \
        [_PLANT / f for f in ("model.py", "kinematics.py", "parameters.py", "trim.py", "linearize.py")]


def default_dir() -> Path:
    return cache_root() / "designs"


def key(kind: str, Tc: float, params: np.ndarray) -> str:
    h = hashlib.sha256(f"{kind}|{Tc!r}".encode())
    h.update(np.asarray(params, dtype=float).tobytes())
    for f in _CODE:
        h.update(f.name.encode() + f.read_bytes())
    for dist in ("cvxpy", "sdpa-python", "clarabel", "numpy", "scipy", "casadi"):
        try:
            h.update(f"{dist}={metadata.version(dist)}".encode())
        except metadata.PackageNotFoundError:
            h.update(f"{dist}=none".encode())
    return h.hexdigest()[:20]


def cached(kind: str, Tc: float, params: np.ndarray, make, folder: Path | None = None) -> Design:
    """The design for these inputs from the cache, or make() it and store it (atomically)."""
    folder = default_dir() if folder is None else Path(folder)
    path = folder / f"{kind}-{key(kind, Tc, params)}.json"
    if path.exists():
        try:
            return artifact.load(path)
        except ValueError:
            pass  # unreadable entry: recompute and overwrite
    design = make()
    tmp = path.with_suffix(f".{os.getpid()}.tmp")
    try:
        artifact.save(design, tmp)
        tmp.replace(path)
    except OSError:
        pass  # a read-only cache only costs time
    return design

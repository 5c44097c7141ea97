"""Designs as versioned JSON artifacts: what the controller FMU will embed at build time.

Floats are written with repr, so a design reloads bit for bit.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

FORMAT = "tiltload-design/1"


@dataclass
class Design:
    kind: str  # "dlqr", "hinf" or "mixed"
    K: np.ndarray  # 4 x (24 + 4 loop_delay); the UAV alone 4 x (20 + 4 loop_delay)
    Tc: float
    trim_x: np.ndarray
    trim_u: np.ndarray
    params: np.ndarray
    A: np.ndarray
    B: np.ndarray
    F: np.ndarray
    omega_chi: np.ndarray
    omega_u: np.ndarray
    report: dict  # figures of merit: spectral radius, residuals, gamma, bounds, timing
    loop_delay: int = 0  # ticks of transport delay the design was made for (error_dynamics.with_loop_delay)
    lmi_point: dict | None = None  # LMI designs: the solver's point (lmi_check.LMIPoint.to_json), checkable again
    origin: str = "synthesized"  # where this copy comes from: synthesized (now), cache (a file), shipped; not saved

    @property
    def parameter_hash(self) -> str:
        return hashlib.sha256(np.asarray(self.params, dtype=float).tobytes()).hexdigest()[:16]


_ARRAYS = ("K", "trim_x", "trim_u", "params", "A", "B", "F", "omega_chi", "omega_u")


def save(design: Design, path: Path) -> Path:
    data = {"format": FORMAT, "kind": design.kind, "Tc": design.Tc, "parameter_hash": design.parameter_hash,
            "report": design.report, "loop_delay": design.loop_delay}
    if design.lmi_point is not None:
        data["lmi_point"] = design.lmi_point
    data.update({k: np.asarray(getattr(design, k)).tolist() for k in _ARRAYS})
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data))
    return path


def load(path: Path, origin: str = "cache") -> Design:
    try:
        data = json.loads(Path(path).read_text())
    except (OSError, json.JSONDecodeError) as err:
        raise ValueError(f"cannot read design {path}: {err}") from None
    if data.get("format") != FORMAT:
        raise ValueError(f"{path} is not a {FORMAT} design (format {data.get('format')!r})")
    try:
        design = Design(kind=data["kind"], Tc=data["Tc"], report=data["report"], loop_delay=int(data.get("loop_delay", 0)),
                        lmi_point=data.get("lmi_point"), origin=origin, **{k: np.array(data[k], dtype=float) for k in _ARRAYS})
    except (KeyError, TypeError, ValueError) as err:
        raise ValueError(f"{path} is not a complete design ({type(err).__name__}: {err})") from None
    if design.K.shape != (4, design.trim_x.size + 4 + 4 * design.loop_delay) or design.parameter_hash != data["parameter_hash"]:
        raise ValueError(f"{path} is inconsistent (gain shape {design.K.shape} or parameter hash)")
    return design

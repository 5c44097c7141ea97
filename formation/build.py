"""The formation's native FMUs as build recipes: FormationController.fmu and TiltrotorTracker.fmu (Appendix B).

Both are C from CasADi (the formation law; the UAV's feedforward) plus hand-written hooks; the tracker
embeds the D-stable H-infinity gain, synthesized once (about 9 s) and cached like the other designs.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

import casadi as ca
import numpy as np

from ..controller_fmu.design import cache as design_cache
from ..native_fmu import casadi_c
from ..native_fmu.build import Prepared, Recipe, tiltload_version
from ..native_fmu.compile import NativeSources
from ..native_fmu.describe_fmi2 import c_array
from ..plant_fmu import codegen
from ..plant_fmu.vehicles import VEHICLES
from . import dstable, fmu_variables, kinematics

HERE = Path(__file__).parent
LAW = HERE.parent / "controller_fmu" / "fmu" / "c"
FORMATION_C = [HERE / "c" / "formation_model.c", HERE / "c" / "formation_model.h"]
TRACKER_C = [HERE / "c" / "tracker_model.c", HERE / "c" / "tracker_model.h", LAW / "tl_law.c", LAW / "tl_law.h",
             LAW / "tl_feedforward_call.h"]
FMU_NAMES = ("FormationController.fmu", "TiltrotorTracker.fmu")


def cached_design(progress=None) -> dict:
    """The D-stable design as plain arrays, from the cache when the code and parameters it depends on are unchanged."""
    code = hashlib.sha256((HERE / "dstable.py").read_bytes()).hexdigest()[:12]
    key = design_cache.key(f"dstable-{code}", fmu_variables.TICK, VEHICLES["uav"].default_parameters())
    path = design_cache.default_dir() / f"dstable-{key}.json"
    try:
        data = json.loads(path.read_text())
        return {k: np.array(v) if isinstance(v, list) else v for k, v in data.items()}
    except (OSError, ValueError):
        pass
    d = dstable.design(progress)
    data = {"K": d.K.tolist(), "gamma": d.gamma, "hinf": list(d.hinf), "trim_x": d.trim_x.tolist(), "trim_u": d.trim_u.tolist(),
            "poles_re": [p.real.tolist() for p in d.poles], "poles_im": [p.imag.tolist() for p in d.poles],
            "seconds": d.seconds, "solver": d.solver, "status": d.status}
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(json.dumps(data))
        tmp.replace(path)
    except OSError:
        pass
    return {k: np.array(v) if isinstance(v, list) else v for k, v in data.items()}


def tracker_data(d: dict) -> str:
    p = VEHICLES["uav"].default_parameters()
    return "\n".join(["/* Generated from the D-stable H-infinity design (formation/dstable.py): do not edit. */",
                      "#ifndef TRACKER_DATA_H", "#define TRACKER_DATA_H",
                      f"#define TL_NX {d['trim_x'].size}", f"#define TL_TC {fmu_variables.TICK!r}",
                      c_array("tl_K", d["K"]), c_array("tl_trim_x", d["trim_x"]), c_array("tl_trim_u", d["trim_u"]),
                      c_array("tl_params", p), "#endif", ""])


def recipes() -> list[Recipe]:
    """The formation controller and the tracker."""
    formation_inputs = (*sorted(HERE.glob("*.py")), *FORMATION_C)
    tracker_inputs = (*sorted(HERE.glob("*.py")), *TRACKER_C, *sorted((HERE.parent / "plant_fmu").glob("*.py")))
    return [Recipe(FMU_NAMES[0], formation_inputs, (ca.__version__,), _prepare_formation),
            Recipe(FMU_NAMES[1], tracker_inputs, (ca.__version__,), _prepare_tracker)]


def _prepare_formation(folder: Path, progress) -> Prepared:
    generated = casadi_c.generate(kinematics.formation_functions(), folder, "tl_formation_gen")
    return Prepared(fmu_variables.formation_definition(tiltload_version()), NativeSources(FORMATION_C, generated))


def _prepare_tracker(folder: Path, progress) -> Prepared:
    d = cached_design(progress)
    generated = casadi_c.generate([codegen.feedforward_function("uav")], folder, "tl_feedforward_gen")
    (folder / "tracker_data.h").write_text(tracker_data(d))
    return Prepared(fmu_variables.tracker_definition(d["trim_x"], tiltload_version()),
                    NativeSources(TRACKER_C, [*generated, folder / "tracker_data.h"]),
                    {"gamma": d["gamma"], "hinf": list(d["hinf"])})

"""Build the formation's native FMUs: FormationController.fmu and TiltrotorTracker.fmu (Appendix B).

Both are C from CasADi (the formation law; the UAV's feedforward) plus hand-written hooks; the tracker
embeds the D-stable H-infinity gain, synthesized once (about 9 s) and cached like the other designs.
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
import time
from pathlib import Path

import casadi as ca
import numpy as np

from ..controller_fmu import cache as design_cache
from ..controller_fmu.fmu_variables import _array
from ..master import packaging
from ..native_fmu import build as native
from ..native_fmu import casadi_c
from ..plant_fmu import codegen
from ..plant_fmu.build import BuildResult
from ..plant_fmu.vehicles import VEHICLES
from . import dstable, fmu_variables, kinematics

HERE = Path(__file__).parent
LAW = HERE.parent / "controller_fmu" / "c"
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
                      _array("tl_K", d["K"]), _array("tl_trim_x", d["trim_x"]), _array("tl_trim_u", d["trim_u"]),
                      _array("tl_params", p), "#endif", ""])


def build(dest: Path, force: bool = False, progress=print) -> list[BuildResult]:
    version = packaging.tiltload_version()
    results = []
    started = time.perf_counter()
    target = Path(dest) / FMU_NAMES[0]
    source_digest = native.digest([*HERE.glob("*.py"), *FORMATION_C, HERE / "dualquat.py"], ca.__version__, version)
    if force or not native.is_current(target, source_digest):
        with tempfile.TemporaryDirectory(prefix="tiltload_formation_") as tmp:
            generated = casadi_c.generate(kinematics.formation_functions(), Path(tmp), "tl_formation_gen")
            built = native.build_fmu(fmu_variables.formation_definition(version), native.NativeSources(FORMATION_C, generated),
                                     target, source_digest, {"version": version})
        results.append(BuildResult(target, True, time.perf_counter() - started, built.warnings))
    else:
        results.append(BuildResult(target, False, time.perf_counter() - started))
    started = time.perf_counter()
    target = Path(dest) / FMU_NAMES[1]
    source_digest = native.digest([*HERE.glob("*.py"), *TRACKER_C, *(HERE.parent / "plant_fmu").glob("*.py")], ca.__version__,
                                  version)
    if force or not native.is_current(target, source_digest):
        d = cached_design(progress)
        with tempfile.TemporaryDirectory(prefix="tiltload_tracker_") as tmp:
            gen = Path(tmp)
            generated = casadi_c.generate([codegen.feedforward_function("uav")], gen, "tl_feedforward_gen")
            (gen / "tracker_data.h").write_text(tracker_data(d))
            built = native.build_fmu(fmu_variables.tracker_definition(d["trim_x"], version),
                                     native.NativeSources(TRACKER_C, [*generated, gen / "tracker_data.h"]), target, source_digest,
                                     {"version": version, "gamma": d["gamma"], "hinf": list(d["hinf"])})
        results.append(BuildResult(target, True, time.perf_counter() - started, built.warnings))
    else:
        results.append(BuildResult(target, False, time.perf_counter() - started))
    return results

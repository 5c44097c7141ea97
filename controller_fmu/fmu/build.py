"""The native controller+estimator FMU as a build recipe: the designs and estimator matrices computed here, run in C.

At build time Python synthesizes (or takes from the cache) the gains and sets up the LKF and ZSE
of Sec. 5.3-5.4; they are embedded as constant arrays. At run time the FMU's C runs the law
u = u_tr - K chi with the CasADi-generated feedforward (3.18), the LKF and the ZSE.
"""

from __future__ import annotations

from functools import partial
from pathlib import Path

import casadi as ca
import numpy as np

from ...native_fmu import casadi_c
from ...native_fmu.build import Prepared, Recipe, tiltload_version
from ...native_fmu.compile import NativeSources
from ...plant_fmu import codegen
from ...sensor_fmu import measurement
from ..design import cache as design_cache
from ..design.error_dynamics import LOOP_DELAYS
from ..design.estimator_setup import augmented_model, lkf_setup, zse_setup
from ..design.synthesize import design
from . import fmu_variables

HERE = Path(__file__).parent
PACKAGE = HERE.parent
FMU_NAMES = {"load": "TiltloadController.fmu", "uav": "TiltrotorController.fmu"}
CLOCKED_FMU_NAMES = {"load": "TiltloadControllerClocked.fmu", "uav": "TiltrotorControllerClocked.fmu"}  # FMI 3.0 only
SE_FMU_NAMES = {"load": "TiltloadControllerSE.fmu", "uav": "TiltrotorControllerSE.fmu"}  # FMI 3.0 Scheduled Execution
FMU_NAME = FMU_NAMES["load"]
C = HERE / "c"
MODEL_C = [C / "controller_model.c", C / "controller_model.h", C / "tl_zse.c", C / "tl_zse.h", C / "tl_lkf.c", C / "tl_lkf.h",
           C / "tl_linalg.c", C / "tl_linalg.h", C / "tl_law.c", C / "tl_law.h", C / "tl_feedforward_call.h"]
HOT = ["tl_zse.c", "tl_linalg.c", "tl_lkf.c"]
TC = 0.012


def bundle(Tc: float = TC, progress=print, vehicle: str = "load") -> dict[str, np.ndarray]:
    """Gains of the designs (cached syntheses; each for loop delays 0, 1, 2 ticks) and the estimator matrices of
    Sec. 5.3-5.4 (Sec. A.4 for the UAV alone: DLQR and ZSE only)."""
    kinds = fmu_variables.CONTROLLERS[vehicle]
    designs = {(kind, d): design(kind, Tc, use_cache=True, progress=progress, vehicle=vehicle, loop_delay=d)
               for kind in kinds for d in LOOP_DELAYS}
    m = augmented_model(Tc, vehicle=vehicle)
    zse = zse_setup(m, vehicle)
    d = designs["dlqr", 0]
    b = {**{f"K_{kind}_d{delay}": designs[kind, delay].K for kind, delay in designs}, "Tc": np.array(Tc),
         "trim_x": d.trim_x, "trim_u": d.trim_u, "params": d.params, "A_nu": m.A, "B_nu": m.B,
         "H_zse": zse.H, "y_eq": zse.y_eq, "G_w": zse.G_w, "G_v": zse.G_v, "G_x0": zse.G_x0, "r_max": np.array(zse.r_max)}
    if "lkf" in fmu_variables.ESTIMATORS[vehicle]:
        lkf = lkf_setup()
        b.update({"H_lkf": lkf.H, "Pw": lkf.Pw, "Pv": lkf.Pv, "P0": lkf.P0})
    return b


def recipe(vehicle: str = "load", clocked: bool = False, scheduled: bool = False) -> Recipe:
    """The controller FMU; clocked: its FMI 3.0 variant, run at the ticks of a periodic input clock of interval T_c;
    scheduled: its FMI 3.0 Scheduled Execution variant (a partition per estimator correction and the law's)."""
    if scheduled:
        return _recipe(vehicle, SE_FMU_NAMES[vehicle], "se")
    return _recipe(vehicle, (CLOCKED_FMU_NAMES if clocked else FMU_NAMES)[vehicle], "clocked" if clocked else "cs")


def _recipe(vehicle: str, name: str, interface: str) -> Recipe:
    plant, sensors = PACKAGE.parent / "plant_fmu", PACKAGE.parent / "sensor_fmu"
    inputs = (*sorted(PACKAGE.rglob("*.py")), *MODEL_C, *sorted(plant.glob("*.py")), sensors / "suite.py",
              sensors / "fmu_variables.py", sensors / "measurement.py")
    return Recipe(name, inputs, (ca.__version__, design_cache.key("all", TC, np.zeros(1)), vehicle,
                                 *((interface,) if interface != "cs" else ())), partial(_prepare, vehicle, interface))


def _prepare(vehicle: str, interface: str, folder: Path, progress) -> Prepared:
    b = bundle(TC, progress, vehicle)
    pi_eq = np.asarray(measurement.pi_codegen_function(vehicle)(b["trim_x"], b["params"])).ravel()
    definition = fmu_variables.definition(b["trim_x"], pi_eq, TC, tiltload_version(), vehicle, interface=interface)
    generated = casadi_c.generate([codegen.feedforward_function(vehicle)], folder, "tl_feedforward_gen")
    (folder / "controller_dims.h").write_text(fmu_variables.dims_header(b, vehicle))
    (folder / "controller_data.h").write_text(fmu_variables.data_header(b, definition, vehicle))
    sources = NativeSources(MODEL_C, [*generated, folder / "controller_dims.h", folder / "controller_data.h"], HOT)
    info = {"Tc": TC, "trim_x": b["trim_x"].tolist(), "trim_u": b["trim_u"].tolist(), "pi_eq": pi_eq.tolist()}
    return Prepared(definition, sources, info)

"""The controller FMU's variables, declared once (the port contract of docs/ports.md), and its C data.

From the build-time bundle (gains, linearization, estimator matrices) this module writes
controller_dims.h (the sizes the C estimators are compiled for) and controller_data.h (every
matrix as a constant array, the ZSE sensor groups and their flags' value references).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ...native_fmu.describe_fmi2 import c_array
from ...native_fmu.variables import Clock, FmuDefinition, Variable
from ...plant_fmu.vehicles import VEHICLES
from ...sensor_fmu.fmu_variables import channel_names, channel_units
from ...sensor_fmu.suite import SUITES
from ..design.error_dynamics import LOOP_DELAYS
from ..reference.zonotope import interval_hull

DESCRIPTION = {
    "load": ("Controller + estimator of Rego (UFMG 2016): DLQR or mixed H2/Hinf with LMI pole regions (ch. 3), "
             "with the exact state, a linearized Kalman filter or a multirate zonotopic state estimator (ch. 4)"),
    "uav": ("Controller + estimator of the tilt-rotor UAV alone (Rego, UFMG 2016, Appendix A): DLQR with integral "
            "action and the exact state or a multirate zonotopic state estimator"),
}
MODEL_IDENTIFIER = {"load": "TiltloadController", "uav": "TiltrotorController"}
REF = ("x_ref", "y_ref", "z_ref", "vx_ref", "vy_ref", "vz_ref", "ax_ref", "ay_ref", "az_ref", "psi_ref", "psi_dot_ref")
REF_UNITS = ("m",) * 3 + ("m/s",) * 3 + ("m/s2",) * 3 + ("rad", "rad/s")
OUTPUTS = (("f_R", "N"), ("f_L", "N"), ("tau_R", "N.m"), ("tau_L", "N.m"))
CONTROLLERS = {"load": ("dlqr", "mixed"), "uav": ("dlqr",)}
ESTIMATORS = {"load": ("none", "lkf", "zse"), "uav": ("none", "zse")}
REDUCTIONS = ("combastel", "girard", "pca")
ZSE_GROUPS = tuple(g for g in SUITES["load"].groups if g.source == "pi")


def zse_groups(vehicle: str = "load"):
    return tuple(g for g in SUITES[vehicle].groups if g.source == "pi")


def extended(vehicle: str = "load") -> tuple[tuple[str, ...], tuple[str, ...]]:
    """The estimate's names and units: the vehicle's states, then the disturbance force."""
    states = VEHICLES[vehicle].states
    return tuple(s[0] for s in states) + ("d_x", "d_y", "d_z"), tuple(s[1] for s in states) + ("N",) * 3


CONTROL_CLOCK = "control_clock"
INTERFACES = ("cs", "clocked", "se")  # co-simulation, with a clock (Event Mode), Scheduled Execution (FMI 3.0)


def correction_clock(group: str) -> str:
    """The Scheduled Execution variant's partition that takes sensor group's samples: the sensor FMU's clock name."""
    return f"{group}_clock"


def partitions(Tc: float, vehicle: str = "load") -> tuple[Clock, ...]:
    """Scheduled Execution: a partition per estimator correction at its sensor group's period, then the law at T_c.
    Priorities rate-monotonic among the corrections (the shorter period first); the law reads every correction of
    its instant, so it ranks below them all (the standard orders one instant's activations by priority)."""
    groups = [g for g in SUITES[vehicle].groups if g.source == "pi" or g.name in ESTIMATORS[vehicle]]
    periods = sorted({g.period for g in groups})
    out = [Clock(correction_clock(g.name), float(g.period), f"estimator correction: the {g.name} samples, every "
                 f"{g.period * 1000:g} ms", 1 + periods.index(g.period)) for g in groups]
    return (*out, Clock(CONTROL_CLOCK, float(Tc), "the law at T_c, with the corrections latched at this instant",
                        1 + len(periods)))


def definition(trim_x, pi_eq, Tc: float, version: str, vehicle: str = "load", clocked: bool = False,
               interface: str = "") -> FmuDefinition:
    """The variable table; clocked (interface "clocked"): the FMI 3.0 variant with one periodic input clock of interval
    T_c that every input and output belongs to (the law runs at its ticks); interface "se": the same variables as the
    Scheduled Execution variant, each sensor group's inputs (samples and flag) clocked by its correction partition,
    the reference, the exact state and every output by the law's."""
    interface = interface or ("clocked" if clocked else "cs")
    names, units = extended(vehicle)
    state_names, state_units = names[:-3], units[:-3]
    suite = SUITES[vehicle]
    who = "load" if vehicle == "load" else "UAV"
    out = lambda n, u, d: Variable(n, "Real", "output", 0.0, d, u, discrete=True)  # noqa: E731
    v = [out(n, u, f"commanded {n} (saturated, held over the tick)") for n, u in OUTPUTS]
    v += [out(f"est_{n}", u, f"estimate of {n}") for n, u in zip(names, units)]
    v += [out(f"est_{n}_lo", u, f"lower bound of {n}: ZSE interval hull, LKF mean - 3 sigma") for n, u in zip(names, units)]
    v += [out(f"est_{n}_hi", u, f"upper bound of {n}: ZSE interval hull, LKF mean + 3 sigma") for n, u in zip(names, units)]
    v += [out("zse_G_frobenius", "", "Frobenius norm of the ZSE generator matrix"),
          out("zse_generators", "1", "number of ZSE generators")]
    v += [Variable(n, "Real", "input", 0.0, f"reference {n[:-4]} at t_k", u) for n, u in zip(REF, REF_UNITS)]
    v += [Variable(f"exact_{n}", "Real", "input", float(trim_x[i]), f"exact state {n} (estimator none)", state_units[i])
          for i, n in enumerate(state_names)]
    if "lkf" in ESTIMATORS[vehicle]:
        v += [Variable(f"lkf_{n}", "Real", "input", float(trim_x[i]), f"measured {n} (estimator lkf)", state_units[i])
              for i, n in enumerate(state_names[:len(state_names) // 2])]
    for g in zse_groups(vehicle):
        v += [Variable(n, "Real", "input", float(pi_eq[i]), f"sensor sample {n[5:]} (estimator zse)", u)
              for n, u, i in zip(channel_names(g, suite), channel_units(g, suite), g.indices)]
    if "lkf" in ESTIMATORS[vehicle]:
        v += [Variable(f"{a}_0", "Real", "parameter", float(trim_x[i]), f"initial {who} {a}, known to the LKF (Sec. 5.3)", "m")
              for i, a in enumerate("xyz")]
    v += [Variable("f_min", "Real", "parameter", 0.0, "actuator limit (Table 5.2)", "N"),
          Variable("f_max", "Real", "parameter", 30.0, "actuator limit (Table 5.2)", "N"),
          Variable("tau_max", "Real", "parameter", 2.0, "actuator limit (Table 5.2)", "N.m"),
          Variable("Tc", "Real", "parameter", Tc, "controller period the designs were made for", "s")]
    v += [Variable("skipped_measurements", "Integer", "output", 0, "measurement entries the estimator skipped this tick"),
          Variable("loop_delay_ticks", "Integer", "parameter", 0,
                   "ticks between measuring and actuating the designs are made for: 0 for tiltload's ordered master, "
                   "2 for a Jacobi master (1 with the exact state; docs/ports.md)", minimum=LOOP_DELAYS[0], maximum=LOOP_DELAYS[-1])]
    v += [Variable(f"{g.name}_new", "Boolean", "input", True, f"the {g.name} sample is new this tick (estimator zse)")
          for g in zse_groups(vehicle)]
    controllers, estimators = CONTROLLERS[vehicle], ESTIMATORS[vehicle]
    v += [Variable("controller", "String", "parameter", controllers[-1],
                   "dlqr or mixed (H2/Hinf with pole regions)" if len(controllers) > 1 else "dlqr (Sec. A.3)"),
          Variable("estimator", "String", "parameter", "zse", " or ".join(estimators) + " (none: the exact state)"),
          Variable("zse_reduction", "String", "parameter", "combastel", "ZSE order reduction: combastel (thesis), girard or pca")]
    clocks = ()
    if interface == "clocked":
        v = [replace(x, clock=CONTROL_CLOCK) if x.causality in ("input", "output") else x for x in v]
        clocks = (Clock(CONTROL_CLOCK, float(Tc), "the controller's period T_c: estimate and law at each tick"),)
    elif interface == "se":
        clocks = partitions(Tc, vehicle)
        v = [replace(x, clock=_partition_of(x.name, vehicle)) if x.causality in ("input", "output") else x for x in v]
    elif interface != "cs":
        raise ValueError(f"interface must be one of {', '.join(INTERFACES)}, got {interface!r}")
    return FmuDefinition(MODEL_IDENTIFIER[vehicle], DESCRIPTION[vehicle], v, "controller_model.h", (0.0, 1.2, Tc),
                         variable_step=False, version=version, clocks=clocks, scheduled=interface == "se")


def _partition_of(name: str, vehicle: str) -> str:
    """The Scheduled Execution partition a port belongs to: a sensor group's samples and flag to its correction, the
    LKF's q to the lkf group's, everything else (reference, exact state, outputs) to the law."""
    suite = SUITES[vehicle]
    for g in zse_groups(vehicle):
        if name == f"{g.name}_new" or name in channel_names(g, suite):
            return correction_clock(g.name)
    if name.startswith("lkf_"):
        return correction_clock("lkf")
    return CONTROL_CLOCK


def estimator_arrays(b: dict) -> dict[str, np.ndarray]:
    """What the C estimators are given, derived from the bundle exactly as the Python estimators derive it."""
    Gwt = np.ascontiguousarray(np.asarray(b["G_w"], dtype=float).T)
    G0 = np.asarray(b["G_x0"], dtype=float).T
    return {"Gw_rows": Gwt, "sigma": interval_hull(np.asarray(b["G_v"], dtype=float).T), "s": -np.asarray(b["y_eq"]),
            "hull_w": interval_hull(Gwt), "Sw": Gwt.T @ Gwt, "c_w": np.zeros(Gwt.shape[1]),
            "G0_rows": G0[np.any(G0 != 0.0, axis=1)]}


def dims_header(b: dict, vehicle: str = "load") -> str:
    e = estimator_arrays(b)
    meas = [n for g in zse_groups(vehicle) for n in channel_names(g, SUITES[vehicle])]
    first, last = min(meas, key=meas.index), meas[-1]
    return "\n".join(["/* Sizes the controller's C estimators are compiled for (generated from the design bundle). */",
                      "#ifndef CONTROLLER_DIMS_H", "#define CONTROLLER_DIMS_H",
                      f"#define TL_NX {b['trim_x'].size}", f"#define TL_NNU {b['A_nu'].shape[0]}",
                      f"#define TL_NY_ZSE {b['H_zse'].shape[0]}",
                      f"#define TL_HAS_LKF {int('H_lkf' in b)}", f"#define TL_HAS_MIXED {int('K_mixed_d0' in b)}",
                      f"#define TL_MAX_DELAY {LOOP_DELAYS[-1]}",
                      f"#define TL_NY_LKF {b['H_lkf'].shape[0] if 'H_lkf' in b else 1}", f"#define TL_R_MAX {int(b['r_max'])}",
                      f"#define TL_RW {e['Gw_rows'].shape[0]}", f"#define TL_N_ZSE_GROUPS {len(zse_groups(vehicle))}",
                      f"#define TL_FIRST_MEAS TL_REAL_{first}", f"#define TL_LAST_MEAS TL_REAL_{last}", "#endif", ""])


def gain_names(b: dict) -> list[str]:
    return [f"K_{kind}_d{d}" for kind in ("dlqr", "mixed") for d in LOOP_DELAYS if f"K_{kind}_d{d}" in b]


def data_header(b: dict, definition: FmuDefinition, vehicle: str = "load") -> str:
    """controller_data.h: the embedded designs and estimator matrices, and the ZSE groups' channels."""
    e = estimator_arrays(b)
    groups = []
    for g in zse_groups(vehicle):
        idx = ", ".join(map(str, g.indices))
        clock = definition.clock_index(correction_clock(g.name)) if definition.scheduled else -1
        groups.append(f"  {{{definition.vr(f'{g.name}_new')}, {clock}, {len(g.indices)}, {{{idx}}}}}")
    lines = ["/* Generated at build time from the designs and the estimator set-up: do not edit. */",
             "#ifndef CONTROLLER_DATA_H", "#define CONTROLLER_DATA_H", "", '#include "controller_dims.h"', "",
             f"#define TL_TC {float(b['Tc'])!r}", f"#define TL_R0 {e['G0_rows'].shape[0]}", f"#define TL_N_PARAMS {b['params'].size}",
             "",
             "/* the gains by controller, then loop delay d (4 x (nx + 4 + 4 d) each) */",
             *(c_array(f"tl_{k}", b[k]) for k in gain_names(b)),
             "static const double* const tl_gains[] = {" + ", ".join(f"tl_{k}" for k in gain_names(b)) + "};",
             c_array("tl_trim_x", b["trim_x"]), c_array("tl_trim_u", b["trim_u"]), c_array("tl_params", b["params"]),
             c_array("tl_A_nu", b["A_nu"]), c_array("tl_B_nu", b["B_nu"]),
             *(c_array(f"tl_{k}", b[k]) for k in ("H_lkf", "Pw", "Pv", "P0") if "H_lkf" in b),
             c_array("tl_H_zse", b["H_zse"]), c_array("tl_zse_c_w", e["c_w"]), c_array("tl_zse_Gw", e["Gw_rows"]),
             c_array("tl_zse_sigma", e["sigma"]), c_array("tl_zse_s", e["s"]), c_array("tl_zse_hull_w", e["hull_w"]),
             c_array("tl_zse_Sw", e["Sw"]), c_array("tl_zse_G0", e["G0_rows"]), "",
             "/* ZSE sensor groups: the Boolean value reference of the group's flag, its correction partition (Scheduled",
             "   Execution: the clock index; -1 otherwise) and the measurements it covers. */",
             "typedef struct { int flag; int clock; int n; int index[16]; } TlZseGroup;",
             "static const TlZseGroup tl_zse_groups[TL_N_ZSE_GROUPS] = {", ",\n".join(groups), "};", "", "#endif", ""]
    return "\n".join(lines)

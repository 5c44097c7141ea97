"""The scenario FMU's variables, declared once, and the C table of the trajectories' durations and starts."""

from __future__ import annotations

from ..native_fmu.variables import FmuDefinition, Variable
from .trajectories import DURATION, START

DESCRIPTION = ("Scenarios of Rego (UFMG 2016) Sec. 5.1: trajectory 1 (circle) or 2 (Table 5.3) for the load, "
               "3 (Appendix A's circle) for the UAV alone, psi_ref = 0, and wind gusts (0.1 N by default) "
               "through 0.5 s first-order lags")
REF = ("x_ref", "y_ref", "z_ref", "vx_ref", "vy_ref", "vz_ref", "ax_ref", "ay_ref", "az_ref")
REF_UNITS = ("m",) * 3 + ("m/s",) * 3 + ("m/s2",) * 3
TRAJECTORIES = (0, 1, 2, 3)  # 0 hover at the origin


def definition(version: str) -> FmuDefinition:
    v = [Variable(n, "Real", "output", 0.0, f"load reference {n[:-4]}", u) for n, u in zip(REF, REF_UNITS)]
    v += [Variable("psi_ref", "Real", "output", 0.0, "load yaw reference", "rad"),
          Variable("psi_dot_ref", "Real", "output", 0.0, "load yaw-rate reference", "rad/s")]
    v += [Variable(f"d_{a}", "Real", "output", 0.0, f"wind force on the load, {a}", "N") for a in "xyz"]
    v += [Variable(f"{a}_start", "Real", "output", 0.0, f"initial load {a} of the scenario (30 cm off the path, Sec. 5.1.2)",
                   "m", discrete=True) for a in "xyz"]
    v.append(Variable("duration", "Real", "output", 0.0, "length of the trajectory", "s", discrete=True))
    v += [Variable("gust_magnitude", "Real", "parameter", 0.1, "size of each wind step", "N"),
          Variable("gust_tau", "Real", "parameter", 0.5, "time constant of the first-order lag", "s")]
    v += [Variable(f"gust_{a}_at", "Real", "parameter", f, f"onset of the {a} gust as a fraction of the duration (reconstructed)",
                   "1") for a, f in zip("xyz", (0.25, 0.5, 0.75))]
    v.append(Variable("trajectory", "Integer", "parameter", 1, "0 hover at the origin, 1 circle (40 s), 2 Table 5.3 (50 s), "
                      "3 Appendix A's circle for the UAV alone (80 s)", minimum=0, maximum=3))
    v.append(Variable("gusts", "Boolean", "parameter", True, "apply the wind gusts"))
    return FmuDefinition("TiltloadScenario", DESCRIPTION, v, "scenario_model.h", (0.0, 40.0, 0.012), version=version)


def trajectory_table(max_w: int) -> str:
    """scenario_table.h: duration and start of each trajectory (0 hover uses 40 s and the origin)."""
    durations = ", ".join(repr(DURATION.get(k, 40.0)) for k in TRAJECTORIES)
    starts = ", ".join("{" + ", ".join(repr(float(x)) for x in START.get(k, (0.0, 0.0, 0.0))) + "}" for k in TRAJECTORIES)
    return "\n".join(["/* Generated from tiltload.scenario_fmu.trajectories: do not edit. */",
                      "#ifndef SCENARIO_TABLE_H", "#define SCENARIO_TABLE_H",
                      f"#define TL_N_TRAJECTORIES {len(TRAJECTORIES)}", f"#define TL_SCENARIO_MAX_W {max_w}",
                      f"static const double tl_duration[TL_N_TRAJECTORIES] = {{{durations}}};",
                      f"static const double tl_start[TL_N_TRAJECTORIES][3] = {{{starts}}};", "#endif", ""])

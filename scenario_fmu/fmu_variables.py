"""The scenario FMU's variables, declared once, and the C table of the thesis trajectories' durations and starts."""

from __future__ import annotations

from ..native_fmu.variables import FmuDefinition, Variable
from .shapes import SHAPE_PARAMETERS, SHAPES
from .trajectories import DURATION, START
from .waypoints import KNOT_COLUMNS, KNOT_LINE, MAX_WAYPOINTS, PATH_LENGTH
from .wind import ALTITUDE_RANGE, MAX_PROFILE, PROFILE_FIELDS

DESCRIPTION = ("Scenarios of Rego (UFMG 2016) Sec. 5.1: trajectory 1 (circle) or 2 (Table 5.3) for the load, "
               "3 (Appendix A's circle) for the UAV alone, psi_ref = 0, and wind gusts (0.1 N by default) "
               "through 0.5 s first-order lags; besides them a minimum-jerk reference through waypoints, "
               "a lemniscate, a lissajous, a step and a ramp, and steady wind, Dryden turbulence (MIL-F-8785C) and a "
               "wind profile as a drag force on the load")
REF = ("x_ref", "y_ref", "z_ref", "vx_ref", "vy_ref", "vz_ref", "ax_ref", "ay_ref", "az_ref")
REF_UNITS = ("m",) * 3 + ("m/s",) * 3 + ("m/s2",) * 3
TRAJECTORIES = (0, 1, 2, 3)  # the thesis's (0 hover at the origin); 4 waypoints, 5-8 the shapes
TRAJECTORY_HELP = ("0 hover at the origin, 1 circle (40 s), 2 Table 5.3 (50 s), 3 Appendix A's circle for the UAV alone "
                   "(80 s), 4 the minimum-jerk reference of the knot file waypoints_file, "
                   + ", ".join(f"{k} {v} (shape_*)" for k, v in SHAPES.items()))


def _wind_variables() -> list[Variable]:
    v = [Variable(f"steady_wind_{a}", "Real", "parameter", 0.0, f"steady wind, {a}", "m/s") for a in "xyz"]
    v += [Variable("dryden_altitude", "Real", "parameter", 10.0, "altitude of the Dryden turbulence's intensities and scale "
                   f"lengths (MIL-F-8785C low altitude: {ALTITUDE_RANGE[0]:.4g} to {ALTITUDE_RANGE[1]:.4g} m)", "m"),
          Variable("dryden_airspeed", "Real", "parameter", 0.0, "speed at which the frozen turbulence passes the vehicle "
                   "(0: the steady wind's speed, or W20 of the severity without steady wind)", "m/s"),
          Variable("drag_area", "Real", "parameter", 3.7e-3, "C_d A of the load: the wind's force is 1/2 rho C_d A |w| w "
                   "(default: a sphere of 5 cm radius, C_d 0.47)", "m2"),
          Variable("air_density", "Real", "parameter", 1.225, "rho of the drag force", "kg/m3")]
    for field in PROFILE_FIELDS:
        unit, what = ("s", "time") if field == "t" else ("m/s", f"wind {field}")
        v += [Variable(f"wind_profile_{field}_{i}", "Real", "parameter", 0.0, f"wind profile row {i}: {what}", unit)
              for i in range(MAX_PROFILE)]
    return v


def definition(version: str) -> FmuDefinition:
    v = [Variable(n, "Real", "output", 0.0, f"load reference {n[:-4]}", u) for n, u in zip(REF, REF_UNITS)]
    v += [Variable("psi_ref", "Real", "output", 0.0, "load yaw reference", "rad"),
          Variable("psi_dot_ref", "Real", "output", 0.0, "load yaw-rate reference", "rad/s")]
    v += [Variable(f"d_{a}", "Real", "output", 0.0, f"wind force on the load, {a}", "N") for a in "xyz"]
    v += [Variable(f"{a}_start", "Real", "output", 0.0, f"initial load {a} of the scenario (30 cm off the path, Sec. 5.1.2; "
                   "on the path for the others)", "m", discrete=True) for a in "xyz"]
    v.append(Variable("duration", "Real", "output", 0.0, "length of the trajectory", "s", discrete=True))
    v += [Variable(f"wind_v{a}", "Real", "output", 0.0, f"wind velocity at the load, {a}: steady + turbulence + profile", "m/s")
          for a in "xyz"]
    v += [Variable(f"turbulence_{c}", "Real", "output", 0.0, f"Dryden component {c} ({what})", "m/s")
          for c, what in zip("uvw", ("along the steady wind, or x", "horizontal, across it", "vertical, up"))]
    v += [Variable(f"dryden_sigma_{c}", "Real", "output", 0.0, f"Dryden intensity of {c}", "m/s", discrete=True) for c in "uvw"]
    v += [Variable(f"dryden_L_{c}", "Real", "output", 0.0, f"Dryden scale length of {c}", "m", discrete=True) for c in "uvw"]
    v.append(Variable("dryden_V", "Real", "output", 0.0, "the speed the Dryden filters use", "m/s", discrete=True))
    v += [Variable("gust_magnitude", "Real", "parameter", 0.1, "size of each wind step", "N"),
          Variable("gust_tau", "Real", "parameter", 0.5, "time constant of the first-order lag", "s")]
    v += [Variable(f"gust_{a}_at", "Real", "parameter", f, f"onset of the {a} gust as a fraction of the duration (reconstructed)",
                   "1") for a, f in zip("xyz", (0.25, 0.5, 0.75))]
    v += [Variable(f"shape_{p.name}", "Real", "parameter", p.default, p.description, p.unit) for p in SHAPE_PARAMETERS]
    v.append(Variable("waypoints_file", "String", "parameter", "", "trajectory 4: the knot file of the minimum-jerk reference "
                      f"(CSV, header {','.join(KNOT_COLUMNS)}; 2 to {MAX_WAYPOINTS} knots); a relative path is in the FMU's "
                      "resources folder (docs/test_bench.md)"))
    v += _wind_variables()
    v.append(Variable("trajectory", "Integer", "parameter", 1, TRAJECTORY_HELP, minimum=0, maximum=max(SHAPES)))
    v.append(Variable("dryden", "Integer", "parameter", 0, "Dryden turbulence: 0 none, 1 light, 2 moderate, 3 severe",
                      minimum=0, maximum=3))
    v.append(Variable("seed", "Integer", "parameter", 1, "seed of the turbulence's noise (Philox, docs/test_bench.md)", minimum=0))
    v.append(Variable("wind_profile_count", "Integer", "parameter", 0, f"rows of the wind profile (0: none, up to {MAX_PROFILE})",
                      minimum=0, maximum=MAX_PROFILE))
    v.append(Variable("gusts", "Boolean", "parameter", True, "apply the wind gusts"))
    return FmuDefinition("TiltloadScenario", DESCRIPTION, v, "scenario_model.h", (0.0, 40.0, 0.012), version=version,
                         string_length=PATH_LENGTH + 1)


def capacity_header() -> str:
    """scenario_capacity.h: the knot file's shape and the tables' capacities (the model state is sized by them)."""
    return "\n".join(["/* Generated from tiltload.scenario_fmu: do not edit. */", "#ifndef SCENARIO_CAPACITY_H",
                      "#define SCENARIO_CAPACITY_H", f"#define TL_MAX_WAYPOINTS {MAX_WAYPOINTS}", f"#define TL_MAX_PROFILE {MAX_PROFILE}",
                      f"#define TL_KNOT_COLUMNS {len(KNOT_COLUMNS)}", f'#define TL_KNOT_HEADER "{",".join(KNOT_COLUMNS)}"',
                      f"#define TL_KNOT_LINE {KNOT_LINE + 2}", "#endif", ""])


def trajectory_table(max_w: int) -> str:
    """scenario_table.h: duration and start of each thesis trajectory (0 hover uses 40 s and the origin), the capacities."""
    durations = ", ".join(repr(DURATION.get(k, 40.0)) for k in TRAJECTORIES)
    starts = ", ".join("{" + ", ".join(repr(float(x)) for x in START.get(k, (0.0, 0.0, 0.0))) + "}" for k in TRAJECTORIES)
    return "\n".join(["/* Generated from tiltload.scenario_fmu: do not edit. */",
                      "#ifndef SCENARIO_TABLE_H", "#define SCENARIO_TABLE_H",
                      f"#define TL_N_TRAJECTORIES {len(TRAJECTORIES)}", f"#define TL_SCENARIO_MAX_W {max_w}",
                      '#include "scenario_capacity.h"',
                      f"#define TL_N_SHAPE_PARAMETERS {len(SHAPE_PARAMETERS)}",
                      f"#define TL_DRYDEN_MIN_ALTITUDE {ALTITUDE_RANGE[0]!r}", f"#define TL_DRYDEN_MAX_ALTITUDE {ALTITUDE_RANGE[1]!r}",
                      f"static const double tl_duration[TL_N_TRAJECTORIES] = {{{durations}}};",
                      f"static const double tl_start[TL_N_TRAJECTORIES][3] = {{{starts}}};", "#endif", ""])

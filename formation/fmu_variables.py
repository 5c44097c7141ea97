"""The formation's two FMUs, their variables declared once (model description and C tables from one list).

FormationController.fmu: backstepping (B.15) or TSID (B.16) on the three UAVs' measured x, y, z, psi
and their rates; its accelerations, integrated once and twice (Sec. B.3.4), are each UAV's references.
TiltrotorTracker.fmu: one UAV's D-stable H-infinity state feedback with the feedforward (Sec. B.3.3).
"""

from __future__ import annotations

from ..controller_fmu.fmu.fmu_variables import OUTPUTS, REF, REF_UNITS
from ..native_fmu.variables import FmuDefinition, Variable
from ..plant_fmu.vehicles import VEHICLES
from .kinematics import AGENTS

TICK = 0.004  # s: the D-stable design's poles reach |s| = 96 rad/s; sampled at 12 ms its loop is unstable (docs/formation.md)
MEASURED = (("x", "m"), ("y", "m"), ("z", "m"), ("psi", "rad"), ("x_dot", "m/s"), ("y_dot", "m/s"), ("z_dot", "m/s"),
            ("psi_dot", "rad/s"))
LAWS = ("backstepping", "tsid")


def formation_definition(version: str) -> FmuDefinition:
    v = []
    for a in AGENTS:
        v += [Variable(f"{a}_{n}_ref", "Real", "output", 0.0, f"reference {n} of UAV {a}", u,
                       discrete=True) for n, u in zip([r[:-4] for r in REF], REF_UNITS)]
    v += [Variable("error_norm", "Real", "output", 0.0, "Euclidean norm of the formation error e_A = x_S - x_d (Fig. B.2)",
                   discrete=True),
          Variable("error_leader", "Real", "output", 0.0, "norm of the leader's part of e_A", discrete=True),
          Variable("error_relative", "Real", "output", 0.0, "norm of the relative pose's part of e_A", discrete=True),
          Variable("error_absolute", "Real", "output", 0.0, "norm of the absolute pose's part of e_A", discrete=True)]
    for a in AGENTS:
        v += [Variable(f"{a}_{n}", "Real", "input", 0.0, f"measured {n} of UAV {a}", u) for n, u in MEASURED]
    v += [Variable("controller", "String", "parameter", "backstepping",
                   "backstepping (B.15, with integral action) or tsid (B.16, task-space inverse dynamics)")]
    for a in AGENTS:
        v += [Variable(f"{a}_a{ax}_disturbance", "Real", "parameter", 0.0,
                       f"constant disturbance added to UAV {a}'s {ax} acceleration reference (Sec. B.4)", "m/s2") for ax in "xyz"]
    v += [Variable("disturbance_start", "Real", "parameter", 0.0, "when the acceleration disturbances begin", "s", minimum=0.0)]
    return FmuDefinition("FormationController", "Formation control of three tilt-rotor UAVs in the cooperative dual "
                         "task-space (Rego, UFMG 2016, Appendix B): backstepping or TSID, references by integration",
                         v, "formation_model.h", (0.0, 40.0, TICK), variable_step=False, version=version)


def tracker_definition(trim_x, version: str) -> FmuDefinition:
    states = VEHICLES["uav"].states
    v = [Variable(n, "Real", "output", 0.0, f"commanded {n} (saturated, held over the tick)", u, discrete=True) for n, u in OUTPUTS]
    v += [Variable(n, "Real", "input", 0.0, f"reference {n[:-4]} at t_k", u) for n, u in zip(REF, REF_UNITS)]
    v += [Variable(name, "Real", "input", float(trim_x[i]), f"measured {meaning}", unit)
          for i, (name, unit, meaning) in enumerate(states)]
    v += [Variable("f_min", "Real", "parameter", 0.0, "actuator limit (Table 5.2)", "N"),
          Variable("f_max", "Real", "parameter", 30.0, "actuator limit (Table 5.2)", "N"),
          Variable("tau_max", "Real", "parameter", 2.0, "actuator limit (Table 5.2)", "N.m")]
    return FmuDefinition("TiltrotorTracker", "Trajectory tracking of one tilt-rotor UAV (Rego, UFMG 2016, Sec. B.3.3): "
                         "D-stable H-infinity state feedback designed on the polytopic model, with the feedforward",
                         v, "tracker_model.h", (0.0, 40.0, TICK), variable_step=False, version=version)

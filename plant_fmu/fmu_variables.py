"""The plant FMU's variables, declared once: they generate its modelDescription.xml and its C tables.

The order is the C model's layout (plant_model.c asserts it): states, diagnostics, applied
inputs, inputs, disturbances, Table 5.1 parameters (the model's parameter vector), actuator
limits, the integrator step and the initial state.
"""

from __future__ import annotations

from ..native_fmu.variables import FmuDefinition, Variable
from . import interface as I
from . import parameters as P

DESCRIPTION = ("Tilt-rotor UAV with suspended load, 10-DOF Euler-Lagrange model from the load's perspective "
               "(Rego, UFMG 2016, ch. 2); fixed-step RK4 on CasADi-generated C")


def definition(trim_x, trim_u, integrator_step: float, version: str) -> FmuDefinition:
    def out(name, unit, desc):
        return Variable(name, "Real", "output", 0.0, desc, unit)

    def par(name, start, unit, desc):
        return Variable(name, "Real", "parameter", float(start), desc, unit)

    variables = [out(n, u, d) for n, u, d in I.STATES]
    variables += [out(n, u, d) for n, u, d in I.DIAGNOSTICS]
    variables += [out(n, u, d) for n, u, d in I.APPLIED]
    variables += [Variable(n, "Real", "input", float(trim_u[i]), d, u) for i, (n, u, d) in enumerate(I.INPUTS)]
    variables += [Variable(n, "Real", "input", 0.0, d, u) for n, u, d in I.DISTURBANCES]
    variables += [par(s.name, s.default, s.unit, s.description) for s in P.MODEL_PARAMETERS]
    variables += [par(s.name, s.default, s.unit, s.description) for s in P.ACTUATOR_LIMITS]
    variables.append(par("integrator_step", integrator_step, "s",
                         "RK4 substep; the communication step must be a whole multiple of it (or smaller)"))
    variables += [par(f"{n}_0", trim_x[i], u, f"initial {d}") for i, (n, u, d) in enumerate(I.STATES)]
    variables += [Variable(f"servo_{side}_stuck", "Boolean", "input", False,
                           f"the {name} servo is stuck at its angle: the tilt joint is held (an actuator fault)")
                  for side, name in (("R", "right"), ("L", "left"))]
    return FmuDefinition("TiltloadPlant", DESCRIPTION, variables, "plant_model.h", (0.0, 2.0, 0.012),
                         variable_step=True, version=version)

"""The controller port contract (docs/ports.md): its names, types and units, checked on a model description.

The contract's inputs are the reference controller's inputs (its variable table,
controller_fmu/fmu/fmu_variables.py, one source), plus the LKF sensor's flag and the plant's states.
"""

from __future__ import annotations

from ...engine.errors import DescriptionError
from .defaults import VEHICLE

REQUIRED_OUTPUTS = ("f_R", "f_L", "tau_R", "tau_L")
OUTPUT_UNITS = {"f_R": "N", "f_L": "N", "tau_R": "N.m", "tau_L": "N.m"}


def contract_inputs(trim_x, pi_eq, vehicle: str = VEHICLE) -> dict[str, tuple[str, str, object, str]]:
    """Every input a controller may declare: name -> (type, unit, start value, description)."""
    from ....controller_fmu.fmu import fmu_variables as cv
    from ....plant_fmu.vehicles import VEHICLES

    d = cv.definition(trim_x, pi_eq, 0.012, "0", vehicle)
    inputs = {v.name: (v.type, v.unit, v.start, v.description) for v in d.variables if v.causality == "input"}
    if vehicle == "load":
        inputs["lkf_new"] = ("Boolean", "", True, "the lkf sample is new this tick")
    for i, (name, unit, _) in enumerate(VEHICLES[vehicle].states):
        inputs[name] = ("Real", unit, float(trim_x[i]), f"plant state {name} (the truth)")
    return inputs


def contract_names(vehicle: str = VEHICLE) -> set[str]:
    """The names of every input the contract has (their types, units and start values: contract_inputs)."""
    import numpy as np

    from ....plant_fmu.vehicles import VEHICLES
    from ....sensor_fmu.suite import SUITES

    return set(contract_inputs(np.zeros(VEHICLES[vehicle].nx), np.zeros(len(SUITES[vehicle].pi_names)), vehicle))


def check_controller(md, allow_unknown_inputs: bool = False, vehicle: str = VEHICLE) -> None:
    """Refuse a controller FMU that lacks a required output, declares one with the wrong type or causality, or
    has an input the contract does not know (it would sit at its start value: a misspelt port) unless allowed."""
    import difflib

    found = {v.name: v for v in md.modelVariables}
    if not allow_unknown_inputs:
        known = contract_names(vehicle)
        for v in md.modelVariables:
            if v.causality == "input" and v.name not in known:
                same_words = [c for c in known if sorted(c.split("_")) == sorted(v.name.split("_"))]
                close = same_words or difflib.get_close_matches(v.name, known, n=1)
                hint = f" (did you mean '{close[0]}'?)" if close else ""
                raise DescriptionError(f"controller FMU {md.modelName}: input '{v.name}' is not a port of the contract{hint}; "
                                       "it would stay at its start value (--allow-unknown-inputs to run anyway)")
    for name in REQUIRED_OUTPUTS:
        v = found.get(name)
        if v is None:
            raise DescriptionError(f"controller FMU {md.modelName}: missing required output '{name}' (docs/ports.md)")
        if v.causality != "output":
            raise DescriptionError(f"controller FMU {md.modelName}: '{name}' must be an output, it is a {v.causality}")
        if v.type != "Real":
            raise DescriptionError(f"controller FMU {md.modelName}: '{name}' must be Real, it is {v.type}")

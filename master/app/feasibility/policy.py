"""The refusal policy: which systems the feasibility check knows (our scenario and plant FMUs), with what limits and
design, and what a problem does: refuses the run with one line, or with --allow-infeasible, a warning. The check
itself: trajectory_check.py; docs/test_bench.md."""

from __future__ import annotations

from ....plant_fmu import parameters as P
from ....plant_fmu.vehicles import VEHICLES
from .trajectory_check import Limits, Report, check_reference


def limits_of(system) -> Limits:
    """Table 5.2's limits, or the controller's f_min, f_max, tau_max where the system sets them."""
    given = {}
    for name in ("plant", "controller"):  # the controller's word wins: it saturates its commands
        try:
            given.update({k: float(v) for k, v in system.instance(name).parameters.items() if k in ("f_min", "f_max", "tau_max")})
        except Exception:
            pass
    return Limits(**given)


_IDENTIFIERS: dict[str, tuple] = {}  # FMU path -> (its size, mtime, inode, its co-simulation model identifier)


def model_identifier(path, instance: str) -> str | None:
    """The co-simulation model identifier of an FMU (None: it has none), its model description read once per version of
    the file (size, modification time, inode): a worker checks one set of FMUs for every case (3 ms a read). Raises as
    read_fmu does."""
    import os

    from ...engine.fmi.model_description import read_fmu

    try:
        st = os.stat(path)
        seen = (st.st_size, st.st_mtime_ns, st.st_ino)
    except OSError:
        seen = None
    known = _IDENTIFIERS.get(str(path))
    if seen is not None and known is not None and known[0] == seen:
        return known[1]
    md = read_fmu(path, instance)
    identifier = md.coSimulation.modelIdentifier if md.coSimulation else None
    if seen is not None:
        _IDENTIFIERS[str(path)] = (seen, identifier)
    return identifier


def vehicle_of(system) -> str | None:
    """load or uav from the plant instance's FMU (TiltloadPlant or TiltrotorUAV), None for another plant."""
    try:
        plant = system.instance("plant")
        identifier = model_identifier(plant.fmu, "plant")
    except Exception:
        return None
    return {"TiltloadPlant": "load", "TiltrotorUAV": "uav"}.get(identifier or "")


def check_system(system, stop: float, max_tilt: float = Limits.max_tilt, explain: bool = True) -> Report | None:
    """The check of a loop system (our scenario and plant FMUs), or None when it is not one this check knows.
    explain=False: the problems alone (trajectory_check.check_reference)."""
    vehicle = vehicle_of(system)
    try:
        identifier = model_identifier(system.instance("scenario").fmu, "scenario")
    except Exception:
        return None
    if vehicle is None or identifier != "TiltloadScenario":
        return None
    scenario = system.instance("scenario").parameters
    plant = {k: v for k, v in system.instance("plant").parameters.items() if k in P.PARAMETER_NAMES}
    limits = limits_of(system)
    design = _our_design(system)
    report = check_reference(scenario, stop, vehicle, plant, Limits(limits.f_min, limits.f_max, limits.tau_max, max_tilt),
                             design=design, explain=explain)
    changed = _changed_plant(vehicle, plant) if explain else None
    if design is not None and changed:
        report.notes.insert(0, nominal_design_note(changed, design[0]))
    return report


def _changed_plant(vehicle: str, plant: dict) -> dict[str, float]:
    """The plant parameters set to other values than the nominal design's (Table 5.1)."""
    v = VEHICLES[vehicle]
    nominal = dict(zip((s.name for s in v.parameter_specs), v.default_parameters()))
    return {k: float(x) for k, x in plant.items() if k in nominal and float(x) != float(nominal[k])}


def nominal_design_note(changed: dict[str, float], kind: str) -> str:
    """One line: a --set of the plant leaves the controller (and the feedforward above) the nominal design."""
    given = ", ".join(f"plant.{k}={x:g}" for k, x in changed.items())
    return (f"--set {given} changes the plant only: the {kind} controller, its estimator and the feedforward stay the "
            "nominal design (Table 5.1's parameters); for a controller of the changed plant, design your own on it, wrap it "
            "(tiltload wrap, docs/ports.md) and run it with --controller IT.fmu")


def _our_design(system) -> tuple[str, int] | None:
    """(dlqr or mixed, loop delay) of our controller FMU in the system; None for a third party's."""
    try:
        ctrl = system.instance("controller")
        identifier = model_identifier(ctrl.fmu, "controller")
    except Exception:
        return None
    if identifier not in ("TiltloadController", "TiltrotorController"):
        return None
    kind = str(ctrl.parameters.get("controller", "dlqr" if identifier == "TiltrotorController" else "mixed"))
    return (kind, int(ctrl.parameters.get("loop_delay_ticks", 0))) if kind in ("dlqr", "mixed") else None


class InfeasibleReference(ValueError):
    """The vehicle cannot fly the reference within its limits; the message is one line naming the first problem."""


def enforce(system, stop: float, allow: bool = False, max_tilt: float = Limits.max_tilt, say=print) -> Report | None:
    """Check a loop system before its first step: say the summary and notes; refuse the first problem (one line),
    or, when allowed, say every problem as a warning."""
    report = check_system(system, stop, max_tilt)
    if report is None:
        return None
    say(report.summary)
    for note in report.notes:
        say(f"note: {note}")
    if report.problems and allow:
        for problem in report.problems:
            say(f"warning: infeasible: {problem}")
    elif report.problems:
        more = len(report.problems) - 1
        raise InfeasibleReference(f"the reference is infeasible: {report.problems[0]}"
                                  + (f" ({more} more problem{'s' * (more > 1)})" if more else "")
                                  + "; --allow-infeasible runs it anyway")
    return report

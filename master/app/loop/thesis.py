"""The tiltload loop as a system description: scenario -> sensors -> controller -> plant, on the 12 ms tick.
Two vehicles: the UAV with its suspended load (ch. 5) and the UAV alone (Appendix A).

What the generic engine does not know of this loop comes from here: its instance names, the
metrics of Sec. 5.1.4 between them, and the controller's loop delay under a given schedule.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ....controller_fmu.design.error_dynamics import LOOP_DELAYS
from ....scenario_fmu.choice import Trajectory
from ...engine import jacobi
from ...engine.errors import DescriptionError
from ...engine.fmi.model_description import clocks_of, read_fmu
from ...engine.metrics import Metrics
from ...engine.system import Connection, Instance, System
from . import defaults
from .inputs import trajectory as as_trajectory

TICK = 0.012
SCENARIOS = {"fsi": "none", "lkf": "lkf", "zse": "zse"}  # thesis scenario -> controller FMU's estimator
PLANT, SENSORS, CONTROLLER, SCENARIO = "plant", "sensors", "controller", "scenario"  # the loop's instance names
TRACKED = (("x", "x_ref"), ("y", "y_ref"), ("z", "z_ref"), ("psi", "psi_ref"))  # ISE: plant output vs reference
COMMANDS = ("f_R", "f_L", "tau_R", "tau_L")  # IADU: the controller's outputs (the port contract's)


@dataclass(frozen=True)
class VehicleLoop:
    """What differs between the two loops: FMU files, the choices the thesis gives, the defaults."""

    plant: str
    sensors: str
    controller: str
    scenarios: tuple[str, ...]
    trajectories: tuple[int, ...]
    controllers: tuple[str, ...]
    default_trajectory: int
    default_controller: str
    gust_magnitude: float  # N


LOOPS = {
    "load": VehicleLoop("TiltloadPlant.fmu", "TiltloadSensors.fmu", "TiltloadController.fmu", ("fsi", "lkf", "zse"),
                        (0, 1, 2), defaults.OUR_CONTROLLERS, 1, defaults.CONTROLLER, 0.1),
    # Appendix A: DLQR with the exact state or the ZSE; Fig. A.3's disturbance profile is lost: 0.5 N steps through
    # the same 0.5 s lags at 1/4, 1/2 and 3/4 of the 80 s circle (chosen; docs/uav.md)
    "uav": VehicleLoop("TiltrotorUAV.fmu", "TiltrotorSensors.fmu", "TiltrotorController.fmu", ("fsi", "zse"),
                       (0, 3), ("dlqr",), 3, "dlqr", 0.5),
}


def clocked_name(fmu_name: str) -> str:
    """The FMI 3.0 variant with clocks of a sensor or controller FMU: TiltloadSensors.fmu -> TiltloadSensorsClocked.fmu."""
    return fmu_name.removesuffix(".fmu") + "Clocked.fmu"


def default_system(fmu_dir: Path, scenario: str = defaults.SCENARIO, trajectory: int | Trajectory | None = None,
                   controller: str | None = None, seed: int = defaults.SEED, controller_fmu: Path | None = None,
                   delay: bool = False, gusts: bool = defaults.GUSTS, vehicle: str = defaults.VEHICLE, wind: dict | None = None,
                   fmi: int | None = None, clocked: bool = False) -> System:
    """The thesis's loop. With controller_fmu, a third-party controller replaces ours (ports: docs/ports.md).
    trajectory: 0-3 or any Trajectory (scenario_fmu.choice: shapes, waypoint files); wind: the scenario FMU's wind
    parameters (scenario_fmu.wind.read_wind), seeded like the sensors. fmi: the FMI version of the FMUs in fmu_dir
    (checked when they load; None: any); clocked: the sensors' and the controller's FMI 3.0 variants with clocks, which
    replace their periods (docs/fmi3.md)."""
    loop = LOOPS[vehicle]
    fmu_dir = Path(fmu_dir)
    named = clocked_name if clocked else (lambda name: name)
    trajectory = as_trajectory(loop.default_trajectory if trajectory is None else trajectory)
    controller = loop.default_controller if controller is None else controller
    start = trajectory.start
    plant_start = {"x_0": start[0], "y_0": start[1], "z_0": start[2]}
    if controller_fmu is None:
        known = {**plant_start} if vehicle == "load" else {}  # the load's LKF knows the start (Sec. 5.3)
        ctrl = Instance(CONTROLLER, fmu_dir / named(loop.controller),
                        parameters={"controller": controller, "estimator": SCENARIOS[scenario], **known}, fmi=fmi,
                        timing="sample")
    else:
        ctrl = Instance(CONTROLLER, Path(controller_fmu), period=controller_period(Path(controller_fmu)), timing="sample")
    conns = [Connection(f"{CONTROLLER}.{u}", f"{PLANT}.{u}", delay=1) for u in COMMANDS] if delay else []
    if trajectory.knots:  # a mission's knot file goes into the machine's cache (the others need no folder)
        from ....controller_fmu.design.cache import cache_root

        scenario_parameters = {**trajectory.fmu_parameters(cache_root() / "missions"), "gusts": gusts}
    else:
        scenario_parameters = {**trajectory.parameters, "gusts": gusts}
    if vehicle != "load":
        scenario_parameters["gust_magnitude"] = loop.gust_magnitude
    if wind:
        scenario_parameters.update({"seed": seed, **wind})
    # the sensors, the controller and the scenario compute their outputs at their step's start (timing "sample"), the
    # plant's are at its step's end (docs/master.md, "Signals at a run's edges")
    return System(TICK, [
        Instance(SCENARIO, fmu_dir / "TiltloadScenario.fmu", parameters=scenario_parameters, fmi=fmi, timing="sample"),
        Instance(SENSORS, fmu_dir / named(loop.sensors), parameters={"seed": seed}, fmi=fmi, timing="sample"),
        ctrl,
        Instance(PLANT, fmu_dir / loop.plant, parameters=plant_start, timing="continuous", fmi=fmi),
    ], conns, fmu_end="error")  # the plant stops when its state diverges: for the loop, a failure


def is_loop(system: System) -> bool:
    """Does the system have the loop's plant, reference and controller instances (so its metrics can be computed)?"""
    return {PLANT, SCENARIO, CONTROLLER} <= {i.name for i in system.instances}


def loop_metrics() -> Metrics:
    """ISE and IADU of Sec. 5.1.4 on the loop's instances."""
    return Metrics(PLANT, SCENARIO, CONTROLLER, TRACKED, COMMANDS)


def select_loop_delay(system: System, schedule: str) -> int | None:
    """Set our controller's loop_delay_ticks to the delay the schedule's master adds to this loop (Jacobi: one tick
    per connection out of a sample-timed FMU), unless already given; return the value set, or None when the controller
    is not ours or was set already. A delay no design exists for is a DescriptionError."""
    mds = {i.name: read_fmu(i.fmu, i.name) for i in system.instances}
    names = {i.name for i in system.instances}
    ours = CONTROLLER in names and any(v.name == "loop_delay_ticks" for v in mds[CONTROLLER].modelVariables)
    if not ours or "loop_delay_ticks" in system.instance(CONTROLLER).parameters:
        return None
    delay = jacobi.loop_delay(jacobi.explicit(system, mds, jacobi=schedule == "jacobi"), mds, CONTROLLER, PLANT, SCENARIO)
    if delay not in LOOP_DELAYS:
        raise DescriptionError(f"the loop would carry {delay} ticks of delay; the designs are made for "
                               f"{LOOP_DELAYS[0]} to {LOOP_DELAYS[-1]}")
    system.instance(CONTROLLER).parameters["loop_delay_ticks"] = delay
    return delay


def controller_period(fmu: Path) -> float | None:
    """A controller FMU runs at its DefaultExperiment stepSize, which must be a whole number of ticks (docs/ports.md);
    an FMI 3.0 one with clocks at its clocks' ticks, which replace the period (None)."""
    md = read_fmu(fmu, CONTROLLER)
    if clocks_of(md):
        return None
    step = md.defaultExperiment.stepSize if md.defaultExperiment is not None else None
    if step in (None, ""):
        return None
    step = float(step)
    n = round(step / TICK)
    if n < 1 or abs(n * TICK - step) > 1e-9:
        raise DescriptionError(f"controller FMU {fmu.name} declares stepSize {step:g} s, not a whole multiple of the "
                               f"{TICK * 1e3:g} ms tick")
    return n * TICK


def default_stop(trajectory: int | Trajectory) -> float:
    """The trajectory's duration; hovering (0) runs 20 s, so that the first gust (at 10 s) excites the loop."""
    return as_trajectory(trajectory).duration


def set_parameters(system: System, values: dict[str, object]) -> System:
    """Set FMU parameters given as {"instance.name": value} (the instance must exist; the FMU checks the name)."""
    for key, value in values.items():
        instance, _, name = key.partition(".")
        if not name:
            raise DescriptionError(f"parameter '{key}' must be written instance.name (e.g. plant.m_L)")
        system.instance(instance).parameters[name] = value
    return system


def parse_value(text: str):
    """A parameter value from the command line: an integer, a number, true/false, or a string."""
    for convert in (int, float):
        try:
            return convert(text)
        except ValueError:
            pass
    return {"true": True, "false": False}.get(text.lower(), text)

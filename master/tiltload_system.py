"""The tiltload loop as a system description: scenario -> sensors -> controller -> plant, on the 12 ms tick.
Two vehicles: the UAV with its suspended load (ch. 5) and the UAV alone (Appendix A)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ..scenario_fmu.trajectories import DURATION, START
from .system import Connection, Instance, System

TICK = 0.012
SCENARIOS = {"fsi": "none", "lkf": "lkf", "zse": "zse"}  # thesis scenario -> controller FMU's estimator


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
                        (0, 1, 2), ("dlqr", "mixed"), 1, "mixed", 0.1),
    # Appendix A: DLQR with the exact state or the ZSE; Fig. A.3's disturbance profile is lost: 0.5 N steps through
    # the same 0.5 s lags at 1/4, 1/2 and 3/4 of the 80 s circle (chosen; docs/uav.md)
    "uav": VehicleLoop("TiltrotorUAV.fmu", "TiltrotorSensors.fmu", "TiltrotorController.fmu", ("fsi", "zse"),
                       (0, 3), ("dlqr",), 3, "dlqr", 0.5),
}


def default_system(fmu_dir: Path, scenario: str = "zse", trajectory: int | None = None, controller: str | None = None,
                   seed: int = 1, controller_fmu: Path | None = None, delay: bool = False, gusts: bool = True,
                   vehicle: str = "load") -> System:
    """The thesis's loop. With controller_fmu, a third-party controller replaces ours (ports: docs/ports.md)."""
    loop = LOOPS[vehicle]
    fmu_dir = Path(fmu_dir)
    trajectory = loop.default_trajectory if trajectory is None else trajectory
    controller = loop.default_controller if controller is None else controller
    start = START.get(trajectory, (0.0, 0.0, 0.0))
    plant_start = {"x_0": start[0], "y_0": start[1], "z_0": start[2]}
    if controller_fmu is None:
        known = {**plant_start} if vehicle == "load" else {}  # the load's LKF knows the start (Sec. 5.3)
        ctrl = Instance("controller", fmu_dir / loop.controller,
                        parameters={"controller": controller, "estimator": SCENARIOS[scenario], **known})
    else:
        ctrl = Instance("controller", Path(controller_fmu), period=controller_period(Path(controller_fmu)))
    conns = [Connection(f"controller.{u}", f"plant.{u}", delay=1) for u in ("f_R", "f_L", "tau_R", "tau_L")] if delay else []
    scenario_parameters = {"trajectory": trajectory, "gusts": gusts}
    if vehicle != "load":
        scenario_parameters["gust_magnitude"] = loop.gust_magnitude
    return System(TICK, [
        Instance("scenario", fmu_dir / "TiltloadScenario.fmu", parameters=scenario_parameters),
        Instance("sensors", fmu_dir / loop.sensors, parameters={"seed": seed}),
        ctrl,
        Instance("plant", fmu_dir / loop.plant, parameters=plant_start, timing="continuous"),
    ], conns)


def controller_period(fmu: Path) -> float | None:
    """A controller FMU runs at its DefaultExperiment stepSize, which must be a whole number of ticks (docs/ports.md)."""
    from .execution import read_fmu
    from .system import DescriptionError

    md = read_fmu(fmu, "controller")
    step = md.defaultExperiment.stepSize if md.defaultExperiment is not None else None
    if step in (None, ""):
        return None
    step = float(step)
    n = round(step / TICK)
    if n < 1 or abs(n * TICK - step) > 1e-9:
        raise DescriptionError(f"controller FMU {fmu.name} declares stepSize {step:g} s, not a whole multiple of the "
                               f"{TICK * 1e3:g} ms tick")
    return n * TICK


def default_stop(trajectory: int) -> float:
    """The trajectory's duration; hovering (0) runs 20 s, so that the first gust (at 10 s) excites the loop."""
    return DURATION.get(trajectory, 20.0)


def set_parameters(system: System, values: dict[str, object]) -> System:
    """Set FMU parameters given as {"instance.name": value} (the instance must exist; the FMU checks the name)."""
    from .system import DescriptionError

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

"""The formation as a system of seven FMU instances for the generic master: the formation controller, one
tracker and one plant per UAV, at the 4 ms tick (fmu_variables.TICK).

Connections are explicit (three plants share their output names, so nothing is connected by name).
The disturbance scenario of Sec. B.4, whose profiles (Fig. B.4) are lost, is chosen here: from
DISTURBANCE_START on, constant acceleration disturbances on the formation controller's outputs
(its parameters) and constant external forces on each UAV (an override of the plant's d_x, d_y, d_z
inputs, through the master's fault injection).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ....formation.fmu_variables import MEASURED, TICK
from ....formation.kinematics import AGENTS, formation_start
from ...engine.faults.schedule import Fault
from ...engine.system import Connection, Instance, System

DURATION = 60.0  # s: long enough to see the backstepping reject the disturbances (time constant ~10 s)
DISTURBANCE_START = 10.0  # s: the loop has settled by then
ACCELERATION_DISTURBANCES = {"sigma": (0.3, -0.2, 0.1), "zeta": (-0.2, 0.3, -0.1), "tau": (0.1, 0.2, 0.3)}  # m/s^2
EXTERNAL_FORCES = {"sigma": (0.5, 0.0, 0.0), "zeta": (0.0, 0.5, 0.0), "tau": (0.0, 0.0, -0.5)}  # N, on each UAV
START_OFFSET = {"sigma": (0.3, -0.2, 0.2), "zeta": (0.4, 0.3, -0.2), "tau": (-0.3, 0.2, 0.3)}  # m, off the formation at t = 0
REFERENCES = ("x_ref", "y_ref", "z_ref", "vx_ref", "vy_ref", "vz_ref", "ax_ref", "ay_ref", "az_ref", "psi_ref", "psi_dot_ref")
STATES = ("x", "y", "z", "phi", "theta", "psi", "alpha_R", "alpha_L", "x_dot", "y_dot", "z_dot", "phi_dot", "theta_dot",
          "psi_dot", "alpha_R_dot", "alpha_L_dot")


def start_positions() -> dict[str, np.ndarray]:
    rho = formation_start(0.0)
    return {a: rho[4 * i:4 * i + 3] + np.array(START_OFFSET[a]) for i, a in enumerate(AGENTS)}


def formation_system(fmu_dir: Path, controller: str = "backstepping", disturbances: bool = False) -> System:
    fmu_dir = Path(fmu_dir)
    starts = start_positions()
    params = {"controller": controller}
    if disturbances:
        params["disturbance_start"] = DISTURBANCE_START
        for a, values in ACCELERATION_DISTURBANCES.items():
            params.update({f"{a}_a{ax}_disturbance": v for ax, v in zip("xyz", values)})
    instances = [Instance("formation", fmu_dir / "FormationController.fmu", parameters=params, timing="sample")]
    instances += [Instance(f"tracker_{a}", fmu_dir / "TiltrotorTracker.fmu", timing="sample") for a in AGENTS]
    instances += [Instance(f"plant_{a}", fmu_dir / "TiltrotorUAV.fmu", timing="continuous",
                           parameters={f"{ax}_0": float(v) for ax, v in zip("xyz", starts[a])}) for a in AGENTS]
    conns = []
    for a in AGENTS:
        conns += [Connection(f"plant_{a}.{n}", f"formation.{a}_{n}") for n, _ in MEASURED]
        conns += [Connection(f"formation.{a}_{r}", f"tracker_{a}.{r}") for r in REFERENCES]
        conns += [Connection(f"plant_{a}.{n}", f"tracker_{a}.{n}") for n in STATES]
        conns += [Connection(f"tracker_{a}.{u}", f"plant_{a}.{u}") for u in ("f_R", "f_L", "tau_R", "tau_L")]
    faults = []
    if disturbances:
        for a, force in EXTERNAL_FORCES.items():
            faults += [Fault("override", [f"plant_{a}.d_{ax}"], DISTURBANCE_START, None, v, name=f"external force on {a}, {ax}")
                       for ax, v in zip("xyz", force) if v]
    return System(TICK, instances, conns, auto_connect=False, faults=faults, fmu_end="error")  # a diverged plant fails

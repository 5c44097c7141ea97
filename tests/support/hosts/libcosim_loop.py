"""Plant, sensors and scenario FMUs in libcosim (libcosimpy), run by a Python that has no numpy.

Usage: python libcosim_loop.py FMU_DIR STOP_TIME [--controller]. Connects the scenario's gust outputs
to the plant and the plant's 20 states to the sensors by name; with --controller, also the ZSE
controller (references, measurements, flags in; thrusts and torques out to the plant) on
trajectory 1. Steps at 12 ms and prints one line 'RESULT {json}' with the final values (every
output of the FMUs) and the simulated time.
"""

import json
import sys

from libcosimpy.CosimEnums import CosimVariableCausality, CosimVariableType
from libcosimpy.CosimExecution import CosimExecution
from libcosimpy.CosimObserver import CosimObserver
from libcosimpy.CosimSlave import CosimLocalSlave

STATES = ["x", "y", "z", "phi", "theta", "psi", "gamma_1", "gamma_2", "alpha_R", "alpha_L"]
STATES += [f"{s}_dot" for s in STATES]
TICK_NS = 12_000_000


REFERENCES = ["x_ref", "y_ref", "z_ref", "vx_ref", "vy_ref", "vz_ref", "ax_ref", "ay_ref", "az_ref", "psi_ref", "psi_dot_ref"]
MEASUREMENTS = ["x_B", "y_B", "z_B", "phi_B", "theta_B", "psi_B", "p_B", "q_B", "r_B", "d_BL_x", "d_BL_y", "d_BL_z",
                "alpha_R", "alpha_L", "alpha_R_dot", "alpha_L_dot"]
FLAGS = ["gps_new", "baro_new", "imu_att_new", "imu_rate_new", "cam_xy_new", "cam_z_new", "servo_angle_new", "servo_rate_new"]
INPUTS = ["f_R", "f_L", "tau_R", "tau_L"]


def main(folder, stop, with_controller):
    execution = CosimExecution.from_step_size(TICK_NS)
    index = {}
    fmus = [("scenario", "TiltloadScenario"), ("sensors", "TiltloadSensors"), ("plant", "TiltloadPlant")]
    if with_controller:
        fmus.insert(2, ("controller", "TiltloadController"))
    for name, fmu in fmus:
        index[name] = execution.add_local_slave(CosimLocalSlave(fmu_path=f"{folder}/{fmu}.fmu", instance_name=name))
        if index[name] < 0:
            raise SystemExit(f"libcosim could not load {fmu}.fmu")
    variables = {name: {v.name.decode(): v for v in execution.slave_variables(i)} for name, i in index.items()}

    def connect(src, dst, names):
        for n in names:
            ok = execution.connect_real_variables(index[src], variables[src][n].reference, index[dst], variables[dst][n].reference)
            if ok != 0:
                raise SystemExit(f"libcosim could not connect {src}.{n} -> {dst}.{n}")

    connect("scenario", "plant", ["d_x", "d_y", "d_z"])
    connect("plant", "sensors", STATES)
    if with_controller:
        connect("scenario", "controller", REFERENCES)
        connect("sensors", "controller", [f"meas_{n}" for n in MEASUREMENTS])
        for n in FLAGS:
            if execution.connect_boolean_variables(index["sensors"], variables["sensors"][n].reference,
                                                   index["controller"], variables["controller"][n].reference) != 0:
                raise SystemExit(f"libcosim could not connect sensors.{n} -> controller.{n}")
        connect("controller", "plant", INPUTS)
        start = {"x_0": 1.7, "y_0": 0.3, "z_0": 0.7}  # trajectory 1's start, 30 cm off the path
        for name in ("plant", "controller"):
            for n, value in start.items():
                execution.real_initial_value(index[name], variables[name][n].reference, value)
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer)
    if not execution.simulate_until(int(round(stop * 1e9))):
        raise SystemExit("libcosim simulation failed")
    result = {"time": execution.status().current_time / 1e9}
    for name, i in index.items():
        for kind, getter in ((CosimVariableType.REAL, observer.last_real_values),
                             (CosimVariableType.BOOLEAN, observer.last_boolean_values)):
            outs = [v for v in variables[name].values()
                    if v.causality == CosimVariableCausality.OUTPUT.value and v.type == kind.value]
            if not outs:
                continue
            values = getter(i, [v.reference for v in outs])
            result.update({f"{name}.{v.name.decode()}": (bool(x) if kind == CosimVariableType.BOOLEAN else x)
                           for v, x in zip(outs, values)})
    print("RESULT " + json.dumps(result), flush=True)  # whole now: libcosim logs on stdout too, at exit


if __name__ == "__main__":
    main(sys.argv[1], float(sys.argv[2]), "--controller" in sys.argv[3:])

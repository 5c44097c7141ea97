"""Plant, sensors and scenario FMUs in libcosim (libcosimpy), run by a Python that has no numpy.

Usage: python libcosim_loop.py FMU_DIR STOP_TIME. Connects the scenario's gust outputs to the
plant and the plant's 20 states to the sensors by name, steps at 12 ms, prints one line 'RESULT {json}'
with the final values (every output of the three FMUs) and the simulated time.
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


def main(folder, stop):
    execution = CosimExecution.from_step_size(TICK_NS)
    index = {}
    for name, fmu in (("scenario", "TiltloadScenario"), ("sensors", "TiltloadSensors"), ("plant", "TiltloadPlant")):
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
    print("RESULT " + json.dumps(result))  # libcosim may log on stdout too


if __name__ == "__main__":
    main(sys.argv[1], float(sys.argv[2]))

"""Every default of a run of the loop, defined once: the loop itself, the case core, the command line's options, the
API's fields, the campaign and falsification specs and the reports read them from here (tests/app/test_case_core.py
scans the code for their literals)."""

from __future__ import annotations

from pathlib import Path

from ....plant_fmu.vehicles import LOAD

SEED = 1  # the sensors' (and wind's) noise seed of a run that names none
SCENARIO = "zse"  # the estimation scenario
SCENARIOS = ("fsi", "lkf", "zse")  # the thesis's: exact state (FSI), linearized Kalman filter, zonotopic estimator
VEHICLE = LOAD.name  # the UAV with its suspended load; "uav": the UAV alone (Appendix A)
OUR_CONTROLLERS = ("dlqr", "mixed")  # the thesis's designs; anything else names a controller FMU
CONTROLLER = "mixed"  # the load's mixed H2/Hinf design (the UAV alone has dlqr only: thesis.LOOPS)
FMU_DIR = Path("fmus")  # where the loop's FMUs are built (the FMI 3.0 set in fmus/fmi3/)
FMI = 2  # the FMI version of the loop's FMUs
GUSTS = True  # the thesis's step gusts on the load
MAX_TILT = 30.0  # degrees: the feasibility check's limit on any trim angle (the designs are linearized at the hover trim)
WORKER_TIMEOUT = 30.0  # s a campaign or a search waits for a cluster's workers

__all__ = ["CONTROLLER", "FMI", "FMU_DIR", "GUSTS", "MAX_TILT", "OUR_CONTROLLERS", "SCENARIO", "SCENARIOS", "SEED", "VEHICLE",
           "WORKER_TIMEOUT"]

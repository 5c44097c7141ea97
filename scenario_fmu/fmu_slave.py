"""The scenario FMU's pythonfmu slave: reference trajectory and wind gusts on the load. Runs only inside a built FMU.

Sample-and-hold, like the sensors and the controller (DESIGN §4): doStep(t_k, h) sets the
outputs to the reference and gusts at t_k and holds them over [t_k, t_k + h); the plant thus
sees the gust as a zero-order hold at the tick. Before the first step they hold t = 0.
"""

import importlib
import json
import math
from pathlib import Path

from pythonfmu import Fmi2Slave
from pythonfmu.default_experiment import DefaultExperiment
from pythonfmu.enums import Fmi2Status

_LIB_DIR = Path(__file__).with_name(Path(__file__).stem + "_lib")
_lib = importlib.import_module(__name__ + "_lib")
_support = importlib.import_module(__name__ + "_lib.slave_support")
_traj = importlib.import_module(__name__ + "_lib.trajectories")
_INFO = json.loads((_LIB_DIR / "build_info.json").read_text())
S = _support

REF = ("x_ref", "y_ref", "z_ref", "vx_ref", "vy_ref", "vz_ref", "ax_ref", "ay_ref", "az_ref")


class TiltloadScenario(Fmi2Slave):
    author = "tiltload"
    description = ("Scenarios of Rego (UFMG 2016) Sec. 5.1: trajectory 1 (circle) or 2 (Table 5.3) for the load, "
                   "psi_ref = 0, and 0.1 N wind gusts on the load through 0.5 s first-order lags")
    default_experiment = DefaultExperiment(start_time=0.0, stop_time=40.0, step_size=0.012)

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.version = _INFO["version"]
        self.modelName = "TiltloadScenario"
        t = self._table = S.VariableTable(self)
        r0 = _traj.reference(1, 0.0).ravel()
        units = ["m"] * 3 + ["m/s"] * 3 + ["m/s2"] * 3
        vrs = [t.real(n, r0[i], S.OUT, S.CONT, f"load reference {n[:-4]}", units[i]) for i, n in enumerate(REF)]
        self._ref = slice(vrs[0], vrs[-1] + 1)
        self._psi = t.real("psi_ref", 0.0, S.OUT, S.CONT, "load yaw reference", "rad")
        self._psi_dot = t.real("psi_dot_ref", 0.0, S.OUT, S.CONT, "load yaw-rate reference", "rad/s")
        self._d = t.block(("d_x", "d_y", "d_z"), (0.0, 0.0, 0.0), S.OUT, S.CONT, lambda n: f"wind force on the load, {n[-1]}", "N")
        start = _traj.START[1]
        self._start = t.block(("x_start", "y_start", "z_start"), start, S.OUT, S.CONT,
                              lambda n: f"initial load {n[0]} of the scenario (30 cm off the path, Sec. 5.1.2)", "m")
        self._duration = t.real("duration", _traj.DURATION[1], S.OUT, S.CONT, "length of the trajectory", "s")
        self._mag = t.real("gust_magnitude", 0.1, S.PARAM, S.FIXED, "size of each wind step", "N")
        self._tau = t.real("gust_tau", 0.5, S.PARAM, S.FIXED, "time constant of the first-order lag", "s")
        self._frac = t.block(("gust_x_at", "gust_y_at", "gust_z_at"), (0.25, 0.5, 0.75), S.PARAM, S.FIXED,
                             lambda n: f"onset of the {n[5]} gust as a fraction of the duration (reconstructed)", "1")
        t.freeze()
        t.typed("integer", "trajectory", 1, S.PARAM, "0 hover at the origin, 1 circle (40 s), 2 Table 5.3 (50 s)")
        t.typed("boolean", "gusts", True, S.PARAM, "apply the wind gusts")
        self._onsets = (0.0, 0.0, 0.0)

    def get_real(self, vrs):
        return self._table.get_real(vrs)

    def set_real(self, vrs, values):
        self._table.set_real(vrs, values)

    def _problem(self):
        t = self._table
        traj = t.other["trajectory"]
        if traj not in (0, 1, 2):
            return f"trajectory must be 0, 1 or 2, got {traj}"
        mag, tau = t.v[self._mag], t.v[self._tau]
        if not (math.isfinite(mag) and math.isfinite(tau) and tau >= 0):
            return f"gust_magnitude must be finite and gust_tau >= 0, got {float(mag)}, {float(tau)}"
        fr = t.v[self._frac]
        if not all(math.isfinite(f) and f >= 0 for f in fr):
            return f"gust onsets must be non-negative fractions, got {fr.tolist()}"
        return None

    def exit_initialization_mode(self):
        problem = self._problem()
        if problem:
            self.log(f"invalid scenario parameters: {problem}", Fmi2Status.error)
            raise ValueError(problem)
        t = self._table
        traj = t.other["trajectory"]
        duration = _traj.DURATION.get(traj, 40.0)
        t.v[self._duration] = duration
        t.v[self._start] = _traj.START.get(traj, (0.0, 0.0, 0.0))
        self._onsets = tuple(f * duration for f in t.v[self._frac])
        self._evaluate(0.0)
        t.initialized = True

    def _evaluate(self, time):
        t = self._table
        t.v[self._ref] = _traj.reference(t.other["trajectory"], time).ravel()
        on = t.other["gusts"]
        mag, tau = t.v[self._mag], t.v[self._tau]
        t.v[self._d] = [_traj.gust(time, onset, mag, tau) if on else 0.0 for onset in self._onsets]

    def do_step(self, current_time, step_size):
        self._evaluate(current_time)
        return True

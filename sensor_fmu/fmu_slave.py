"""The sensor-suite FMU's pythonfmu slave. It runs only inside a built FMU.

Inputs: the plant's 20 states by their stable names. Outputs: the exact state (`exact_<state>`,
full-state scenario), the LKF-scenario sensor (`lkf_<q>`), the ZSE-scenario sensors
(`meas_<name>` of (4.22)) and one `<group>_new` flag per sensor group. The sample of
doStep(t_k, h) uses the inputs set before the call (the state at t_k) and is held until the
next sample (DESIGN §4: sensors -> controller -> plant within a tick).
"""

import importlib
import json
import math
from pathlib import Path

import numpy as np
from pythonfmu import Fmi2Slave
from pythonfmu.default_experiment import DefaultExperiment
from pythonfmu.enums import Fmi2Status

_LIB_DIR = Path(__file__).with_name(Path(__file__).stem + "_lib")
_lib = importlib.import_module(__name__ + "_lib")
_iface = importlib.import_module(__name__ + "_lib.interface")
_support = importlib.import_module(__name__ + "_lib.slave_support")
_suite = importlib.import_module(__name__ + "_lib.suite")
_native = importlib.import_module(__name__ + "_lib.native")
_INFO = json.loads((_LIB_DIR / "build_info.json").read_text())
S = _support


class TiltloadSensors(Fmi2Slave):
    author = "tiltload"
    description = ("Sensor suite of Rego (UFMG 2016): exact state, q with Gaussian noise (Sec. 5.3), GPS, barometer, "
                   "IMU, camera and servo encoders with their periods and noise (Table 5.8)")
    default_experiment = DefaultExperiment(start_time=0.0, stop_time=1.2, step_size=0.012)

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.version = _INFO["version"]
        self.modelName = "TiltloadSensors"
        t = self._table = S.VariableTable(self)
        trim_x = _INFO["trim_x"]
        names = _iface.STATE_NAMES
        self._in = t.block(names, trim_x, S.INPUT, S.CONT, lambda n: f"true state {n} (from the plant)")
        self._exact = t.block([f"exact_{n}" for n in names], trim_x, S.OUT, S.CONT, lambda n: f"{n}: exact state channel")
        g = _suite.GROUPS
        self._out = []
        pi_eq = _INFO["pi_eq"]
        for grp in g:
            if grp.source == "q":
                labels, starts = [f"lkf_{names[i]}" for i in grp.indices], [trim_x[i] for i in grp.indices]
            else:
                labels, starts = [f"meas_{_suite.ZSE_NAMES[i]}" for i in grp.indices], [pi_eq[i] for i in grp.indices]
            self._out.append(t.block(labels, starts, S.OUT, S.DISCRETE, lambda n, grp=grp: f"{n}: {grp.name} sample (held)", grp.unit))
        self._period = [t.real(f"{grp.name}_period", grp.period, S.PARAM, S.FIXED, f"{grp.name} sampling period", "s") for grp in g]
        self._bound = []
        for grp in g:
            bounds = grp.bound if isinstance(grp.bound, tuple) else (grp.bound,)
            labels = ([f"{grp.name}_bound_{names[i]}" for i in grp.indices] if len(bounds) > 1 else [f"{grp.name}_bound"])
            self._bound.append(t.block(labels, bounds, S.PARAM, S.FIXED,
                                       f"{grp.name} noise bound (3 sigma if gaussian, half-width if uniform)", grp.unit))
        self._step_vr = t.real("step", 0.012, S.PARAM, S.FIXED, "tick: the communication step the suite expects", "s")
        self._l_vr = t.real("l", _INFO["params"][_INFO["l_index"]], S.PARAM, S.FIXED, "rod length, as in the plant", "m")
        t.freeze()
        t.typed("integer", "seed", 1, S.PARAM, "seed of every noise stream")
        for grp in g:
            t.typed("string", f"{grp.name}_pdf", grp.pdf, S.PARAM, f"{grp.name} noise distribution: gaussian or uniform")
        for grp in g:
            t.typed("boolean", f"{grp.name}_new", False, S.OUT, f"{grp.name} took a new sample this step")
        self._pi = _native.CasadiFunction(_LIB_DIR / _INFO["library"], "tl_pi")
        self._p = np.array(_INFO["params"], dtype=float)
        self._pi_x = np.zeros(16)
        self._sensors = None

    def get_real(self, vrs):
        return self._table.get_real(vrs)

    def set_real(self, vrs, values):
        self._table.set_real(vrs, values)

    def exit_initialization_mode(self):
        t = self._table
        g = _suite.GROUPS
        try:
            self._sensors = _suite.SensorSuite(
                t.other["seed"], t.v[self._step_vr], [t.v[vr] for vr in self._period],
                [t.v[sl].copy() for sl in self._bound], [t.other[f"{grp.name}_pdf"] for grp in g])
        except _suite.SensorError as err:
            self.log(f"invalid sensor parameters: {err}", Fmi2Status.error)
            raise
        l_rod = t.v[self._l_vr]
        if not (math.isfinite(l_rod) and l_rod > 0):
            self.log(f"invalid sensor parameters: l must be positive and finite, got {l_rod!r}", Fmi2Status.error)
            raise ValueError("l")
        self._p[_INFO["l_index"]] = l_rod
        t.initialized = True

    def do_step(self, current_time, step_size):
        t = self._table
        step = t.v[self._step_vr]
        if abs(step_size - step) > 1e-9 * step:
            self.log(f"communication step {step_size:.9g} s differs from the suite's step {step:.9g} s; step refused",
                     Fmi2Status.error)
            return False
        x = t.v[self._in]
        if not np.all(np.isfinite(x)):
            bad = [_iface.STATE_NAMES[i] for i in np.flatnonzero(~np.isfinite(x))]
            self.log(f"non-finite state input at t={current_time:.6g} s: {', '.join(bad)}; step refused", Fmi2Status.error)
            return False
        k = int(math.floor(current_time / step + 0.5))
        self._pi([np.ascontiguousarray(x), self._p], [self._pi_x])
        s = self._sensors
        s.sample(k, x[:10], self._pi_x)
        t.v[self._exact] = x
        for i, grp in enumerate(_suite.GROUPS):
            t.v[self._out[i]] = s.values[i]
            t.other[f"{grp.name}_new"] = bool(s.new[i])
        return True

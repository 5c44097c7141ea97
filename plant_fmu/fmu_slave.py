"""The plant FMU's pythonfmu slave. It runs only inside a built FMU.

The build copies this file to resources/<unique>.py and the run-time part of the plant
package to resources/<unique>_lib/ (DESIGN §6: unique names per FMU and build), with the
compiled model and build_info.json (defaults, trim). Every Real lives in one array indexed
by value reference, so the compiled model reads inputs and parameters and writes states and
outputs in place, and no attribute can shadow a variable.
"""

import importlib
import json
import math
from pathlib import Path

import numpy as np
from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real
from pythonfmu.default_experiment import DefaultExperiment
from pythonfmu.enums import Fmi2Initial, Fmi2Status

_LIB_DIR = Path(__file__).with_name(Path(__file__).stem + "_lib")
_lib = importlib.import_module(__name__ + "_lib")
_iface = importlib.import_module(__name__ + "_lib.interface")
_params = importlib.import_module(__name__ + "_lib.parameters")
_native = importlib.import_module(__name__ + "_lib.native")
_INFO = json.loads((_LIB_DIR / "build_info.json").read_text())


class TiltloadPlant(Fmi2Slave):
    author = "tiltload"
    description = (
        "Tilt-rotor UAV with suspended load, 10-DOF Euler-Lagrange model from the load's "
        "perspective (Rego, UFMG 2016, ch. 2); fixed-step RK4 on compiled CasADi code"
    )
    default_experiment = DefaultExperiment(start_time=0.0, stop_time=2.0, step_size=0.012)

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.version = _INFO["version"]
        self.modelName = "TiltloadPlant"
        self._values = []  # start values in value-reference order, frozen into an array below
        self._settable_inputs = []
        self._settable_params = []
        trim_x = _INFO["trim"]["x"]
        trim_u = _INFO["trim"]["u"]

        def add(name, start, causality, variability, unit, desc, initial=None):
            vr = len(self._values)
            self._values.append(float(start))
            self.register_variable(
                Real(
                    name, start=float(start), causality=causality, variability=variability,
                    initial=initial, description=f"{desc} [{unit}]",
                    getter=lambda vr=vr: self._v[vr], setter=lambda value, vr=vr: self._set(vr, value),
                )
            )
            return vr

        out, cont = Fmi2Causality.output, Fmi2Variability.continuous
        exact = Fmi2Initial.exact
        # layout: [states | diagnostics | applied inputs | inputs | disturbances | params | limits | step | x0]
        sx = [add(n, trim_x[i], out, cont, unit, desc, exact) for i, (n, unit, desc) in enumerate(_iface.STATES)]
        sy = [add(n, 0.0, out, cont, unit, desc, exact) for n, unit, desc in _iface.DIAGNOSTICS]
        sa = [add(n, trim_u[i], out, cont, unit, desc, exact) for i, (n, unit, desc) in enumerate(_iface.APPLIED)]
        su = [add(n, trim_u[i], Fmi2Causality.input, cont, unit, desc) for i, (n, unit, desc) in enumerate(_iface.INPUTS)]
        sd = [add(n, 0.0, Fmi2Causality.input, cont, unit, desc) for n, unit, desc in _iface.DISTURBANCES]
        par, fixed = Fmi2Causality.parameter, Fmi2Variability.fixed
        sp = [add(s.name, s.default, par, fixed, s.unit, s.description) for s in _params.MODEL_PARAMETERS]
        sl = [add(s.name, s.default, par, fixed, s.unit, s.description) for s in _params.ACTUATOR_LIMITS]
        sh = add("integrator_step", _INFO["integrator_step"], par, fixed, "s",
                 "RK4 substep; the communication step must be a whole multiple of it (or smaller)")
        s0 = [add(f"{n}_0", trim_x[i], par, fixed, unit, f"initial {desc}") for i, (n, unit, desc) in enumerate(_iface.STATES)]

        self._v = np.array(self._values, dtype=float)
        v = self._v
        self._x, self._y, self._applied = v[sx[0]:sx[-1] + 1], v[sy[0]:sy[-1] + 1], v[sa[0]:sa[-1] + 1]
        self._u, self._d = v[su[0]:su[-1] + 1], v[sd[0]:sd[-1] + 1]
        self._p, self._limits, self._x0 = v[sp[0]:sp[-1] + 1], v[sl[0]:sl[-1] + 1], v[s0[0]:s0[-1] + 1]
        self._h_vr = sh
        self._inputs_vr = set(su + sd)
        self._params_vr = set(sp + sl + [sh] + s0)
        self._names = {var.value_reference: var.name for var in self.vars.values()}
        self._plant = _native.NativePlant(_LIB_DIR / _INFO["library"])
        self._plant.bind(self._x, self._applied, self._d, self._p, self._y)
        self._initialized = False
        self._failed = None
        self._lo, self._hi, self._tau = self._limits.tolist()
        self._saturate()
        self._plant.evaluate()

    # --- FMI variable access: one array, checked causality --------------------------------
    def _set(self, vr, value):
        if vr in self._inputs_vr or (vr in self._params_vr and not self._initialized):
            self._v[vr] = value
            return
        what = "a parameter after initialization" if vr in self._params_vr else "an output"
        self.log(f"cannot set {self._names[vr]}: it is {what}", Fmi2Status.error)
        raise ValueError(f"cannot set {self._names[vr]}")

    def get_real(self, vrs):
        return self._v[vrs].tolist()

    def set_real(self, vrs, values):
        if self._initialized and self._inputs_vr.issuperset(vrs):
            self._v[vrs] = values  # the hot path: inputs during the run
            return
        for vr, value in zip(vrs, values):
            self._set(vr, value)

    # --- lifecycle --------------------------------------------------------------------------
    def exit_initialization_mode(self):
        lim = dict(zip((s.name for s in _params.ACTUATOR_LIMITS), self._limits))
        problem = None
        try:
            _params.validate(self._p, lim)
        except _params.ParameterError as err:
            problem = str(err)
        h = self._v[self._h_vr]
        if problem is None and not (math.isfinite(h) and h > 0.0):
            problem = f"integrator_step must be a positive finite time, got {h!r}"
        if problem is None and not np.isfinite(self._x0).all():
            bad = [_iface.STATE_NAMES[i] + "_0" for i in np.flatnonzero(~np.isfinite(self._x0))]
            problem = f"non-finite initial state: {', '.join(bad)}"
        if problem is not None:
            self.log(f"invalid plant parameters: {problem}", Fmi2Status.error)
            raise ValueError(problem)
        self._lo, self._hi, self._tau = lim["f_min"], lim["f_max"], lim["tau_max"]
        self._x[:] = self._x0
        self._saturate()
        self._plant.evaluate()
        self._initialized = True

    def _saturate(self, f_r=None, f_l=None, t_r=None, t_l=None):
        """Actuator limits of Table 5.2: the plant applies what the actuators can deliver."""
        if f_r is None:
            f_r, f_l, t_r, t_l = self._u.tolist()
        lo, hi, tau = self._lo, self._hi, self._tau
        self._applied[:] = (min(max(f_r, lo), hi), min(max(f_l, lo), hi), min(max(t_r, -tau), tau), min(max(t_l, -tau), tau))

    def _refuse(self, message):
        self.log(message, Fmi2Status.error)
        return False

    def do_step(self, current_time, step_size):
        if self._failed is not None:
            return self._refuse(f"plant stopped at t={self._failed:.6g} s after an earlier error; no further steps")
        h = self._v[self._h_vr]
        if step_size <= h * (1.0 + 1e-9):
            n, sub = 1, step_size
        else:
            n = round(step_size / h)
            if abs(n * h - step_size) > 1e-6 * step_size:
                return self._refuse(
                    f"communication step {step_size:.9g} s is not a whole multiple of integrator_step {h:.9g} s"
                )
            sub = step_size / n
        u = self._u.tolist()
        if not math.isfinite(sum(u) + sum(self._d.tolist())):  # nan or inf anywhere
            names = _iface.INPUT_NAMES + _iface.DISTURBANCE_NAMES
            values = u + self._d.tolist()
            bad = ", ".join(f"{n}={v}" for n, v in zip(names, values) if not math.isfinite(v))
            return self._refuse(f"non-finite input at t={current_time:.6g} s: {bad}; step refused")
        self._saturate(*u)
        status = self._plant.step(sub, n)
        if status != 0:
            self._failed = current_time
            if status < 0:
                return self._refuse(f"plant model evaluation failed at t={current_time:.6g} s")
            return self._refuse(
                f"state diverged (non-finite) in substep {status} of the step from t={current_time:.6g} s; "
                "the state is kept at its last value and the plant stops"
            )
        return True

"""The controller+estimator FMU's pythonfmu slave. It runs only inside a built FMU.

Port contract: docs/ports.md. The designs and estimator matrices were computed at build time
(resources/<unique>_lib/bundle.npz); each doStep(t_k, T_c) reads the reference and sensor
inputs at t_k, runs the estimator and the control law, and holds u_k over the step.
"""

import importlib
import json
from pathlib import Path

import numpy as np
from pythonfmu import Fmi2Slave
from pythonfmu.default_experiment import DefaultExperiment
from pythonfmu.enums import Fmi2Status

_LIB_DIR = Path(__file__).with_name(Path(__file__).stem + "_lib")
_lib = importlib.import_module(__name__ + "_lib")
_iface = importlib.import_module(__name__ + "_lib.interface")
_support = importlib.import_module(__name__ + "_lib.slave_support")
_runtime = importlib.import_module(__name__ + "_lib.runtime")
_suite = importlib.import_module(__name__ + "_lib.suite")
_native = importlib.import_module(__name__ + "_lib.native")
_INFO = json.loads((_LIB_DIR / "build_info.json").read_text())
S = _support

REF = ("x_ref", "y_ref", "z_ref", "vx_ref", "vy_ref", "vz_ref", "ax_ref", "ay_ref", "az_ref", "psi_ref", "psi_dot_ref")
ZSE_GROUPS = [g for g in _suite.GROUPS if g.source == "pi"]


class TiltloadController(Fmi2Slave):
    author = "tiltload"
    description = ("Controller + estimator of Rego (UFMG 2016): DLQR or mixed H2/Hinf with LMI pole regions (ch. 3), "
                   "with the exact state, a linearized Kalman filter or a multirate zonotopic state estimator (ch. 4)")
    default_experiment = DefaultExperiment(start_time=0.0, stop_time=1.2, step_size=_INFO["Tc"])

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.version = _INFO["version"]
        self.modelName = "TiltloadController"
        t = self._table = S.VariableTable(self)
        trim_x, trim_u = _INFO["trim_x"], _INFO["trim_u"]
        names = _iface.STATE_NAMES
        self._u = t.block(("f_R", "f_L", "tau_R", "tau_L"), trim_u, S.OUT, S.DISCRETE,
                          lambda n: f"commanded {n} (saturated, held over the tick)", "N, N m")
        ext = names + ("d_x", "d_y", "d_z")
        self._est = t.block([f"est_{n}" for n in ext], trim_x + [0.0] * 3, S.OUT, S.DISCRETE, lambda n: f"estimate of {n[4:]}")
        self._lo = t.block([f"est_{n}_lo" for n in ext], trim_x + [0.0] * 3, S.OUT, S.DISCRETE,
                           lambda n: f"lower bound of {n[4:-3]}: ZSE interval hull, LKF mean - 3 sigma")
        self._hi = t.block([f"est_{n}_hi" for n in ext], trim_x + [0.0] * 3, S.OUT, S.DISCRETE,
                           lambda n: f"upper bound of {n[4:-3]}: ZSE interval hull, LKF mean + 3 sigma")
        self._frob = t.real("zse_G_frobenius", 0.0, S.OUT, S.DISCRETE, "Frobenius norm of the ZSE generator matrix")
        self._ngen = t.real("zse_generators", 0.0, S.OUT, S.DISCRETE, "number of ZSE generators")
        self._ref = t.block(REF, [0.0] * len(REF), S.INPUT, S.CONT, lambda n: f"reference {n[:-4]} at t_k")
        self._exact = t.block([f"exact_{n}" for n in names], trim_x, S.INPUT, S.CONT, lambda n: f"exact state {n[6:]} (estimator none)")
        self._lkf = t.block([f"lkf_{n}" for n in names[:10]], trim_x[:10], S.INPUT, S.CONT, lambda n: f"measured {n[4:]} (estimator lkf)")
        self._meas = t.block([f"meas_{n}" for n in _suite.ZSE_NAMES], _INFO["pi_eq"], S.INPUT, S.CONT,
                             lambda n: f"sensor sample {n[5:]} (estimator zse)")
        self._start = t.block(("x_0", "y_0", "z_0"), trim_x[:3], S.PARAM, S.FIXED,
                              lambda n: f"initial load {n[0]}, known to the LKF (Sec. 5.3)", "m")
        self._limits = t.block(("f_min", "f_max", "tau_max"), (0.0, 30.0, 2.0), S.PARAM, S.FIXED, "actuator limit (Table 5.2)")
        self._tc = t.real("Tc", _INFO["Tc"], S.PARAM, S.FIXED, "controller period the designs were made for", "s")
        t.freeze()
        t.typed("string", "controller", "mixed", S.PARAM, "dlqr or mixed (H2/Hinf with pole regions)")
        t.typed("string", "estimator", "zse", S.PARAM, "none (exact state), lkf or zse")
        t.typed("string", "zse_reduction", "combastel", S.PARAM, "ZSE order reduction: combastel (thesis), girard or pca")
        for g in ZSE_GROUPS:
            t.typed("boolean", f"{g.name}_new", True, S.INPUT, f"the {g.name} sample is new this tick (estimator zse)")
        t.typed("integer", "skipped_measurements", 0, S.OUT, "measurement entries the estimator skipped this tick")
        self._bundle = dict(np.load(_LIB_DIR / "bundle.npz"))
        self._p = self._bundle["params"]
        self._ff = _native.CasadiFunction(_LIB_DIR / _INFO["library"], "tl_feedforward")
        self._ff_out = np.zeros(4)
        self._rt = None

    def _feedforward(self, x_tr, qdd):
        self._ff([np.ascontiguousarray(x_tr), np.ascontiguousarray(qdd), self._p], [self._ff_out])
        return self._ff_out.copy()

    def get_real(self, vrs):
        return self._table.get_real(vrs)

    def set_real(self, vrs, values):
        self._table.set_real(vrs, values)

    def exit_initialization_mode(self):
        t = self._table
        try:
            tc = t.v[self._tc]
            if abs(tc - _INFO["Tc"]) > 1e-12:
                raise _runtime.SetupError(f"Tc = {float(tc)} s, but the embedded designs are for {_INFO['Tc']} s (rebuild to change it)")
            self._rt = _runtime.ControllerRuntime(
                self._bundle, t.other["controller"], t.other["estimator"], self._feedforward,
                tuple(t.v[self._limits]), t.v[self._start].copy(), t.other["zse_reduction"])
        except _runtime.SetupError as err:
            self.log(f"invalid controller parameters: {err}", Fmi2Status.error)
            raise
        t.initialized = True

    def do_step(self, current_time, step_size):
        t, tc = self._table, _INFO["Tc"]
        if abs(step_size - tc) > 1e-9 * tc:
            self.log(f"communication step {step_size:.9g} s is not the controller period T_c = {tc} s; step refused",
                     Fmi2Status.error)
            return False
        v = t.v
        available = np.zeros(16, dtype=bool)
        for g in ZSE_GROUPS:
            available[list(g.indices)] = bool(t.other[f"{g.name}_new"])
        rt = self._rt
        ref = v[self._ref]
        if not np.all(np.isfinite(ref)):
            self.log(f"non-finite reference at t={current_time:.6g} s; step refused", Fmi2Status.error)
            return False
        u = rt.step(ref, v[self._exact], v[self._lkf], v[self._meas], available)
        if not np.all(np.isfinite(u)) or not np.all(np.isfinite(rt.estimate)):
            self.log(f"the controller produced a non-finite input or estimate at t={current_time:.6g} s "
                     f"(estimator {rt.estimator}); step refused", Fmi2Status.error)
            return False
        v[self._u] = u
        v[self._est] = np.r_[rt.estimate, rt.disturbance]
        v[self._lo], v[self._hi] = rt.lower, rt.upper
        v[self._frob], v[self._ngen] = rt.frobenius, rt.generators
        t.other["skipped_measurements"] = len(rt.flags)
        if rt.flags:
            self.log(f"t={current_time:.6g} s: skipped measurement entries {rt.flags} (non-finite or inconsistent)",
                     Fmi2Status.warning)
        return True

"""The pythonfmu slave `tiltload wrap` builds around a user's Python controller. Runs only inside that FMU.

resources/<unique>_lib/ holds the user's module and wrap.json (the ports the controller asked for,
with their contract types, units and start values, its parameters and its period). Values live in
dictionaries, never as attributes, so no port name can shadow the slave's own fields (docs/ports.md, "Your own controller in Python").
"""

import importlib
import json
import math
from pathlib import Path

from pythonfmu import Boolean, Fmi2Causality, Fmi2Slave, Fmi2Variability, Real
from pythonfmu.default_experiment import DefaultExperiment
from pythonfmu.enums import Fmi2Initial, Fmi2Status

_LIB = Path(__file__).with_name(Path(__file__).stem + "_lib")
_SPEC = json.loads((_LIB / "wrap.json").read_text())
_USER = importlib.import_module(__name__ + "_lib." + _SPEC["module"])


class TiltloadWrapped(Fmi2Slave):
    author = _SPEC["author"]
    description = _SPEC["description"]
    default_experiment = DefaultExperiment(start_time=0.0, stop_time=1.2, step_size=_SPEC["period"])

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.modelName = _SPEC["model"]
        self._in = {}
        self._out = {}
        self._par = {}
        for name, (typ, unit, start, desc) in _SPEC["inputs"].items():
            self._in[name] = start
            cls = Boolean if typ == "Boolean" else Real
            extra = {"variability": Fmi2Variability.discrete} if typ == "Boolean" else {}
            self.register_variable(cls(name, causality=Fmi2Causality.input, start=start, description=f"{desc} [{unit}]" if unit else desc,
                                       getter=lambda n=name: self._in[n], setter=lambda v, n=name: self._in.__setitem__(n, v), **extra))
        for name, (unit, start) in _SPEC["outputs"].items():
            self._out[name] = start
            self.register_variable(Real(name, causality=Fmi2Causality.output, variability=Fmi2Variability.discrete,
                                        initial=Fmi2Initial.exact, start=start, description=f"command [{unit}]",
                                        getter=lambda n=name: self._out[n]))
        for name, start in _SPEC["parameters"].items():
            self._par[name] = start
            self.register_variable(Real(name, causality=Fmi2Causality.parameter, variability=Fmi2Variability.fixed, start=start,
                                        getter=lambda n=name: self._par[n], setter=lambda v, n=name: self._par.__setitem__(n, v)))
        self._controller = None

    def exit_initialization_mode(self):
        cls = getattr(_USER, _SPEC["class"])
        try:
            self._controller = cls(**self._par) if self._par else cls()
        except (Exception, SystemExit) as err:  # the user's code (sys.exit() too): say what it raised, in one line
            self.log(f"{_SPEC['class']}() raised {type(err).__name__} ({err})", Fmi2Status.error)
            raise

    def do_step(self, current_time, step_size):
        try:
            u = self._controller.step(current_time, dict(self._in))
            u = [float(v) for v in u]
        except (Exception, SystemExit) as err:
            self.log(f"{_SPEC['class']}.step raised {type(err).__name__} at t={current_time:.6g} s ({err})", Fmi2Status.error)
            return False
        if len(u) != 4:
            self.log(f"{_SPEC['class']}.step returned {len(u)} values at t={current_time:.6g} s; it must return "
                     "(f_R, f_L, tau_R, tau_L)", Fmi2Status.error)
            return False
        if not all(math.isfinite(v) for v in u):
            self.log(f"{_SPEC['class']}.step returned a non-finite command at t={current_time:.6g} s: {u}", Fmi2Status.error)
            return False
        for name, value in zip(("f_R", "f_L", "tau_R", "tau_L"), u):
            self._out[name] = value
        return True

"""Controllers written outside tiltload (plain state feedback), for the controller-swap tests.

Their gain comes from scipy's DARE on a linearization passed in by the test; the controllers
know nothing of tiltload. `user_controller` writes a Python class for `tiltload wrap` (modes
"ok" and "nan": NaN after 1 s). `build` makes a pythonfmu FMU by hand, for the faults `tiltload
wrap` refuses to produce: "missing" (no tau_L output), "int" (tau_L declared Integer).
"""

USER = '''
import numpy as np

K = np.array({K})
X_EQ = np.array({x_eq})
U_EQ = np.array({u_eq})
STATES = {states}


class ThirdPartyLQR:
    """State feedback u = u_eq - K (x - x_eq - ref), from the exact-state channel."""

    inputs = [f"exact_{{n}}" for n in STATES] + ["x_ref", "y_ref", "z_ref"]

    def step(self, t, inputs):
        x = np.array([inputs[f"exact_{{n}}"] for n in STATES]) - X_EQ
        x[0:3] -= [inputs["x_ref"], inputs["y_ref"], inputs["z_ref"]]
        u = U_EQ - K @ x
        if {nan} and t >= 1.0:
            u[0] = float("nan")
        return u.tolist()
'''


def user_controller(folder, K, x_eq, u_eq, states, mode="ok"):
    """A controller class file for `tiltload wrap`; returns its path."""
    from pathlib import Path

    path = Path(folder) / f"third_party_{mode}.py"
    path.write_text(USER.format(K=K.tolist(), x_eq=list(map(float, x_eq)), u_eq=list(map(float, u_eq)), states=list(states),
                                nan=mode == "nan"))
    return path

SLAVE = r'''
import json
from pathlib import Path

import numpy as np
from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Integer, Real
from pythonfmu.enums import Fmi2Initial

DATA = json.loads((Path(__file__).parent / "gain.json").read_text())
STATES = DATA["states"]


class ThirdPartyLQR(Fmi2Slave):
    author = "someone else"
    description = "state feedback u = u_eq - K (x - x_eq - ref), from the exact-state channel"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.xs = {n: x for n, x in zip(STATES, DATA["x_eq"])}
        for n in STATES:
            self.register_variable(Real(f"exact_{n}", causality=Fmi2Causality.input, start=self.xs[n],
                                        getter=lambda n=n: self.xs[n], setter=lambda v, n=n: self.xs.__setitem__(n, v)))
        self.ref = {"x_ref": 0.0, "y_ref": 0.0, "z_ref": 0.0}
        for n in self.ref:
            self.register_variable(Real(n, causality=Fmi2Causality.input, start=0.0,
                                        getter=lambda n=n: self.ref[n], setter=lambda v, n=n: self.ref.__setitem__(n, v)))
        self.u = list(DATA["u_eq"])
        outputs = ["f_R", "f_L", "tau_R", "tau_L"] if DATA["mode"] != "missing" else ["f_R", "f_L", "tau_R"]
        for i, n in enumerate(outputs):
            if DATA["mode"] == "int" and n == "tau_L":
                self.register_variable(Integer(n, causality=Fmi2Causality.output, variability=Fmi2Variability.discrete,
                                               initial=Fmi2Initial.exact, start=0, getter=lambda: 0))
                continue
            self.register_variable(Real(n, causality=Fmi2Causality.output, variability=Fmi2Variability.discrete,
                                        initial=Fmi2Initial.exact, start=self.u[i], getter=lambda i=i: self.u[i]))

    def do_step(self, current_time, step_size):
        x = np.array([self.xs[n] for n in STATES]) - np.array(DATA["x_eq"])
        x[0:3] -= [self.ref["x_ref"], self.ref["y_ref"], self.ref["z_ref"]]
        u = np.array(DATA["u_eq"]) - np.array(DATA["K"]) @ x
        if DATA["mode"] == "nan" and current_time >= 1.0:
            u[0] = float("nan")
        self.u = np.r_[np.clip(u[:2], 0, 30), np.clip(u[2:], -2, 2)].tolist() if np.all(np.isfinite(u)) else u.tolist()
        return True
'''


def build(folder, K, x_eq, u_eq, states, mode="ok"):
    import json
    from pathlib import Path

    from pythonfmu.builder import FmuBuilder

    folder = Path(folder)
    src = folder / f"src_{mode}"
    src.mkdir(parents=True, exist_ok=True)
    script = src / f"third_party_lqr_{mode}.py"
    script.write_text(SLAVE.replace("ThirdPartyLQR", f"ThirdPartyLQR{mode.capitalize()}"))
    data = src / "gain.json"
    data.write_text(json.dumps({"K": K.tolist(), "x_eq": list(x_eq), "u_eq": list(u_eq), "states": list(states), "mode": mode}))
    return FmuBuilder.build_FMU(script, dest=folder, project_files=[data], needsExecutionTool=False)

"""ISE against loop delay: the thesis's designs (made for no delay) and the delay-aware ones, 0, 1 and 2 ticks.

For each design (DLQR, mixed H2/Hinf) and loop delay d, the closed-loop spectral radius on the
linear model with d ticks of transport delay (error_dynamics.with_loop_delay), and the ISE of the
nonlinear loop through the FMUs (trajectory 1, 40 s, seed 1, gusts) with the exact state (FSI) and
with the ZSE. Delay 1 is the actuation delay (`--delay`: controller -> plant one tick late); delay 2
is what a Jacobi master adds (libcosim, Ecos: master/engine/jacobi.py). "plain" runs the design made for
d = 0 (loop_delay_ticks 0), "aware" the one made for d. A run that diverges shows the time it stopped.

Run: python benchmarks/loop_delay.py   (prints the Markdown table of docs/controller.md)
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
from tiltload.controller_fmu.design.error_dynamics import error_dynamics, with_loop_delay
from tiltload.controller_fmu.design.synthesize import design
from tiltload.master.app.loop.fmus import build_all
from tiltload.master.app.loop.thesis import default_system, loop_metrics
from tiltload.master.engine import jacobi
from tiltload.master.engine.fmi.model_description import read_fmu
from tiltload.master.engine.run import run_system

STOP = 40.0


def spectral_radius(kind: str, made_for: int, d: int) -> float:
    """Closed loop of the design made for made_for ticks on the model with d ticks (made_for 0 or d)."""
    model = with_loop_delay(error_dynamics(0.012), d)
    K = design(kind, use_cache=True, loop_delay=made_for).K
    K = np.hstack([K, np.zeros((4, model.A.shape[0] - K.shape[1]))])  # a plain design ignores the commands on their way
    return float(np.abs(np.linalg.eigvals(model.A - model.B @ K)).max())


def loop(fmus: Path, scenario: str, kind: str, d: int, aware: bool):
    system = default_system(fmus, scenario, 1, kind, delay=d == 1)
    if d == 2:
        system = jacobi.explicit(system, {i.name: read_fmu(i.fmu, i.name) for i in system.instances}, jacobi=True)
    system = dataclasses.replace(system)
    system.instance("controller").parameters["loop_delay_ticks"] = d if aware else 0
    return run_system(system, STOP, None, loop_metrics(), progress=False)


def main() -> None:
    fmus = Path("fmus")
    build_all(fmus)
    print(f"trajectory 1, {STOP:g} s, seed 1, gusts; ISE(x) + ISE(y) + ISE(z) in m^2 s; rho: closed-loop spectral radius "
          "on the linear model with the delay\n")
    print("| design | loop delay (ticks) | made for | rho | ISE FSI | ISE ZSE |")
    print("|---|---|---|---|---|---|")
    for kind in ("dlqr", "mixed"):
        for d in (0, 1, 2):
            for aware in ((False,) if d == 0 else (False, True)):
                rho = spectral_radius(kind, d if aware else 0, d)
                cells = []
                for scenario in ("fsi", "zse"):
                    r = loop(fmus, scenario, kind, d, aware)
                    ise = sum(r.metrics[f"ISE({a})"] for a in "xyz")
                    cells.append(f"diverged at {r.sim_time:.2f} s" if r.error else f"{ise:.4f}")
                made_for = f"{d} (aware)" if aware else "0 (plain)"
                print(f"| {kind} | {d} | {made_for} | {rho:.5f} | {cells[0]} | {cells[1]} |", flush=True)


if __name__ == "__main__":
    main()

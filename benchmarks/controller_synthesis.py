"""Synthesis time and figures of merit of the three designs (docs/controller.md; target mixed <= 10 s).

Wall clock of tiltload.controller_fmu.design.design(kind), one run each, on this machine;
the LMI designs are solved by SDPA through cvxpy, Clarabel as fallback (solver time printed separately).
Run: python benchmarks/controller_synthesis.py
"""

from __future__ import annotations

import numpy as np
from tiltload.controller_fmu.design.synthesize import design


def main() -> None:
    print(f"{'design':>7} {'total s':>8} {'solver s':>9} {'rho':>9} {'min Re':>7} {'Hinf bound':>11} "
          f"{'Hinf meas':>10} {'H2 bound':>9} {'H2 meas':>8} {'||K||':>7}")
    for kind in ("dlqr", "hinf", "mixed"):
        d = design(kind)
        r = d.report
        poles = np.linalg.eigvals(d.A - d.B @ d.K)
        f = lambda key: f"{r[key]:.4g}" if r.get(key) is not None else "-"  # noqa: E731
        print(f"{kind:>7} {r['seconds']:>8.1f} {r.get('solver_seconds', 0.0):>9.1f} {np.abs(poles).max():>9.6f} "
              f"{poles.real.min():>7.3f} {f('gamma_bound'):>11} {f('hinf_norm'):>10} {f('h2_bound'):>9} "
              f"{f('h2_norm'):>8} {r['gain_norm']:>7.4g}")
    again = design("mixed")
    print(f"mixed synthesized twice: gains bit-identical = {np.array_equal(d.K, again.K)}; "
          f"second run {again.report['seconds']:.1f} s")
    print("thesis (Sec. 5.2): pure Hinf bound 17.4617; mixed with gamma~ = 24^2 reaches ||.||_2 < sqrt(33.1099) = 5.754")


if __name__ == "__main__":
    main()

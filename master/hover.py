"""Main job for now: build the FMUs if needed and run the plant FMU's default experiment.

It shows, through FMPy exactly as a user's tool would run it, that the plant hovers at its
trim, and reports the trim and the open-loop eigenvalues a controller has to handle.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from .packaging import read_build_info
from .pythonfmu_guard import pin


def main(args: argparse.Namespace) -> int:
    from fmpy import simulate_fmu
    from fmpy.util import write_csv

    from ..plant_fmu import build as plant_build

    result = plant_build.build(args.fmus)
    print(f"{result.path}: {'built' if result.rebuilt else 'up to date'} ({result.seconds:.1f} s)")
    info = read_build_info(result.path)
    pin(result.path)
    res = simulate_fmu(str(result.path), stop_time=args.stop_time)
    t_end = res["time"][-1]
    drift = max(float(np.max(np.abs(res[n] - res[n][0]))) for n in ("x", "y", "z"))
    trim = info["trim"]
    q = dict(zip(["x", "y", "z", "phi", "theta", "psi", "gamma_1", "gamma_2", "alpha_R", "alpha_L"], trim["x"]))
    print("\nhover trim (thesis Table 5.1 parameters), residual max|L_in u - g| = " f"{trim['residual']:.1e}")
    for name in ("gamma_1", "gamma_2", "alpha_R", "alpha_L"):
        print(f"  {name:<8} {q[name]: .6e} rad")
    for name, value in zip(("f_R", "f_L", "tau_R", "tau_L"), trim["u"]):
        print(f"  {name:<8} {value: .6f} {'N' if name.startswith('f') else 'N m'}")
    eig = np.array([complex(*e) for e in info["open_loop_eigenvalues"]])
    shown = sorted({(round(e.real, 3), round(abs(e.imag), 3)) for e in eig if abs(e) > 1e-6})
    print("open-loop eigenvalues (non-zero, 1/s): " + ", ".join(
        f"{re:+.3f}" + (f"±{im:.3f}j" if im else "") for re, im in shown))
    print(f"\nopen-loop hover, {len(res)} points to t = {t_end:.3f} s: load drift {drift:.2e} m")
    args.out.mkdir(parents=True, exist_ok=True)
    csv = args.out / "plant_hover.csv"
    write_csv(str(csv), res)
    png = args.out / "plant_hover.png"
    _plot(res, eig, png)
    print(f"results: {csv}\nplot:    {png}")
    return 0


def _plot(res, eig, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4))
    for n in ("x", "y", "z", "x_B", "y_B", "z_B"):
        a.plot(res["time"], res[n] - res[n][0], label=f"{n} - {n}(0)")
    a.set(xlabel="t [s]", ylabel="drift [m]", title="Open-loop hover at the trim (plant FMU)")
    a.legend(fontsize=7)
    b.axvline(0, color="0.7", lw=0.8)
    b.scatter(eig.real, eig.imag, marker="x")
    b.set(xlabel="Re [1/s]", ylabel="Im [rad/s]", title="Open-loop eigenvalues at the trim")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)

"""The figures and numbers of docs/test_bench.md: run from the repository, `python benchmarks/test_bench_figures.py`.

Flies docs/examples/mission.csv with both designs (FSI, with docs/examples/gusty_wind.yaml), plots the reference and the
flown paths, checks docs/examples/sprint.csv, and measures the Dryden turbulence of the scenario FMU over a long run
through a C host (tests/support/hosts/wind_host.c): variance, 1/e correlation time, the correlation curve.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
FIGURES = ROOT / "docs" / "figures"
EXAMPLES = ROOT / "docs" / "examples"
TICK = 0.012


def mission(fmus: Path) -> None:
    from tiltload.master.app.feasibility.trajectory_check import check_reference
    from tiltload.master.app.loop.inputs import READER
    from tiltload.master.app.loop.thesis import default_system, loop_metrics
    from tiltload.master.engine.log import reader as log_reader
    from tiltload.master.engine.run import run_system
    from tiltload.scenario_fmu import choice, twin
    from tiltload.scenario_fmu.wind import read_wind

    m = choice.resolve(str(EXAMPLES / "mission.csv"), read=READER)
    t = np.arange(0, m.duration + 2, 0.003)
    s = twin.evaluate(m.fmu_parameters(Path(tempfile.mkdtemp())), t)
    fig, axes = plt.subplots(3, 1, figsize=(9, 7), sharex=True)
    for ax, values, label in zip(axes, (s.p, s.v, s.a), ("position (m)", "velocity (m/s)", "acceleration (m/s2)")):
        for k, a in enumerate("xyz"):
            ax.plot(t, values[:, k], label=a)
        ax.set_ylabel(label)
        for knot in (k[0] for k in m.knots):
            ax.axvline(knot, color="0.85", lw=0.8, zorder=0)
    axes[0].legend(ncol=3)
    axes[-1].set_xlabel("t (s)")
    axes[0].set_title("docs/examples/mission.csv: the minimum-jerk reference (grey: the waypoints' times)")
    fig.tight_layout()
    fig.savefig(FIGURES / "test_bench_mission_reference.png", dpi=110)
    plt.close(fig)

    wind = read_wind(EXAMPLES / "gusty_wind.yaml", READER)
    fig = plt.figure(figsize=(9, 4.5))
    ax3 = fig.add_subplot(1, 2, 1, projection="3d")
    ax2 = fig.add_subplot(1, 2, 2)
    ax3.plot(*s.p.T, "k--", lw=1, label="reference")
    ax2.plot(s.p[:, 0], s.p[:, 1], "k--", lw=1, label="reference")
    rows = []
    for controller in ("dlqr", "mixed"):
        for scenario in ("fsi", "zse"):
            with tempfile.TemporaryDirectory() as tmp:
                res = run_system(default_system(fmus, scenario, m, controller, seed=3, wind=wind), m.duration,
                                 Path(tmp) / "m.mcap", loop_metrics(), progress=False)
                plant = log_reader.read(res.log, topics=["/plant"])["/plant"]
            xyz = np.array([[p["x"], p["y"], p["z"]] for p in plant])
            rows.append((scenario, controller, res.error, res.metrics))
            if scenario == "fsi":
                ax3.plot(*xyz.T, label=controller)
                ax2.plot(xyz[:, 0], xyz[:, 1], label=controller)
    ax2.set_xlabel("x (m)")
    ax2.set_ylabel("y (m)")
    ax2.set_aspect("equal")
    ax2.legend()
    ax3.set_title("mission.csv, FSI, with gusty_wind.yaml")
    fig.tight_layout()
    fig.savefig(FIGURES / "test_bench_mission_flown.png", dpi=110)
    plt.close(fig)
    print("mission.csv, seed 3, gusty_wind.yaml:")
    print(f"  {'scenario':8} {'design':6} " + " ".join(f"{k:>10}" for k in ("ISE(x)", "ISE(y)", "ISE(z)", "ISE(psi)")))
    for scenario, controller, error, metrics in rows:
        print(f"  {scenario:8} {controller:6} " + " ".join(f"{metrics[k]:10.4g}" for k in ("ISE(x)", "ISE(y)", "ISE(z)", "ISE(psi)"))
              + (f"  ERROR {error}" if error else ""))
    sprint = choice.resolve(str(EXAMPLES / "sprint.csv"), read=READER)
    report = check_reference(sprint.fmu_parameters(Path(tempfile.mkdtemp())), sprint.duration)
    print("sprint.csv:", report.problems[0] if report.problems else "feasible")
    for text in ("1", "2"):
        th = choice.resolve(text, read=READER)
        print(f"trajectory {text}:", check_reference(th.parameters, th.duration, design=("mixed", 0)).summary)


def dryden(fmus: Path, stop: float = 60000.0) -> None:
    from fmpy import extract, read_model_description
    from tiltload.scenario_fmu import wind

    fmu = fmus / "TiltloadScenario.fmu"
    md = read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(extract(str(fmu), tmp))
        host = folder / "wind_host"
        subprocess.run(["cc", "-std=c11", "-O2", f"-I{folder / 'sources'}", str(ROOT / "tests/support/hosts/wind_host.c"), "-o",
                        str(host), "-ldl", "-lm"], check=True)
        fig, axes = plt.subplots(1, 3, figsize=(11, 3.4))
        print(f"Dryden, {stop:g} s at the {TICK * 1e3:g} ms tick (C host), seeds 11, 12, 13:")
        for seed, (severity, altitude) in enumerate(((1, 10.0), (2, 10.0), (3, 30.0)), start=11):
            model = wind.dryden(severity, altitude)
            started = time.perf_counter()
            out = subprocess.run([str(host), str(folder / "binaries/linux64/TiltloadScenario.so"), md.guid, repr(stop), repr(TICK),
                                  f"i{vr['trajectory']}=0", f"i{vr['dryden']}={severity}", f"i{vr['seed']}={seed}",
                                  f"r{vr['dryden_altitude']}={altitude!r}",
                                  *(f"o{vr[n]}" for n in ("turbulence_u", "turbulence_v", "turbulence_w"))],
                                 capture_output=True, check=True).stdout
            wall = time.perf_counter() - started
            x = np.frombuffer(out).reshape(-1, 3)
            cells = []
            for c in range(3):
                lags = int(4 * model.time_constants[c] / TICK)
                n = 1 << int(np.ceil(np.log2(x.shape[0] + lags)))
                f = np.fft.rfft(x[:, c], n)
                acov = np.fft.irfft(f * np.conj(f), n)[:lags] / (x.shape[0] - np.arange(lags))
                rho = acov / acov[0]
                k = int(np.argmax(rho < np.exp(-1)))
                tau = TICK * (k - 1 + (rho[k - 1] - np.exp(-1)) / (rho[k - 1] - rho[k]))
                tau_model = wind.correlation_time(c) * model.time_constants[c]
                curve = model.correlation(np.arange(lags) * TICK)[c] / model.sigma[c] ** 2
                cells.append(f"{'uvw'[c]}: var {np.mean(x[:, c] ** 2) / model.sigma[c] ** 2 - 1:+.2%}, "
                             f"tau {tau / tau_model - 1:+.2%} ({tau_model:.3g} s), max|rho - R| {np.abs(rho - curve).max():.3f}")
                if severity == 2:
                    axes[c].plot(np.arange(lags) * TICK, rho, label="measured")
                    axes[c].plot(np.arange(lags) * TICK, curve, "k--", label="MIL-F-8785C")
                    axes[c].set_title(f"{'uvw'[c]}: sigma {model.sigma[c]:.2f} m/s, L {model.length[c]:.1f} m")
                    axes[c].set_xlabel("lag (s)")
            name = {1: "light", 2: "moderate", 3: "severe"}[severity]
            print(f"  {name} at {altitude:g} m (V {model.airspeed:.2f} m/s, {wall:.1f} s wall): " + "; ".join(cells))
        axes[0].set_ylabel("normalized autocorrelation")
        axes[0].legend()
        fig.suptitle("Dryden turbulence of TiltloadScenario.fmu, moderate at 10 m, 60000 s: measured vs the model")
        fig.tight_layout()
        fig.savefig(FIGURES / "test_bench_dryden_correlation.png", dpi=110)
        plt.close(fig)


if __name__ == "__main__":
    from tiltload.master.app.loop.fmus import build_all

    fmus = ROOT / "fmus"
    build_all(fmus, progress=lambda *_: None)
    if "--dryden-only" not in sys.argv:
        mission(fmus)
    dryden(fmus)

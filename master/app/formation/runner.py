"""`tiltload formation`: the seven-FMU formation through the generic master, logged and plotted.

Each run writes runs/formation/<controller>[_disturbed].mcap: every FMU's outputs and one 3D scene per UAV
(/scene/plant_sigma, ...). The figures: the error norm of both controllers (Fig. B.2 / B.3 kind) and the
UAVs' paths in 3D and from above (Fig. B.5 kind).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ....formation.kinematics import AGENTS  # noqa: E402
from ...engine.log import reader as log_reader  # noqa: E402
from ...engine.run import RunResult, run_system  # noqa: E402
from ..loop.scene import scene_channels  # noqa: E402
from .system import DISTURBANCE_START, DURATION, formation_system  # noqa: E402

LABEL = {"sigma": "leader σ", "zeta": "follower ζ", "tau": "follower τ"}


@dataclass
class FormationRun:
    controller: str
    log: Path
    result: RunResult
    t: np.ndarray
    error: np.ndarray  # ||e_A|| at each step

    def settled(self, last: float = 5.0) -> float:
        """The largest error norm over the last seconds of the run: the steady-state error."""
        return float(self.error[self.t >= self.t[-1] - last].max())


def run(fmus: Path, out: Path, controller: str, disturbances: bool, stop: float = DURATION, progress: bool = True) -> FormationRun:
    system = formation_system(fmus, controller, disturbances)
    log = Path(out) / f"{controller}{'_disturbed' if disturbances else ''}.mcap"
    meta = {"system": "formation (Appendix B)", "controller": controller, "disturbances": disturbances, "stop_time": stop}
    result = run_system(system, stop, log, None, progress=progress, metadata=meta,
                        channels=scene_channels(tuple(f"plant_{a}" for a in AGENTS)))
    t, error = np.empty(0), np.empty(0)
    if log.is_file():
        msgs = log_reader.read(log, topics=["/formation"]).get("/formation", [])[1:]  # the first is before any step
        t = np.array([m["t"] for m in msgs])
        error = np.array([m["error_norm"] for m in msgs])
    return FormationRun(controller, log, result, t, error)


def plot(runs: list[FormationRun], out: Path, disturbances: bool) -> list[Path]:
    """The error norms of the runs on one axis, and each run's paths (3D and top view)."""
    out = Path(out)
    suffix = "_disturbed" if disturbances else ""
    files = []
    fig, ax = plt.subplots(figsize=(7, 3.6))
    for r in runs:
        ax.plot(r.t, r.error, label=r.controller)
    if disturbances:
        ax.axvline(DISTURBANCE_START, color="grey", ls="--", lw=0.8, label="disturbances on")
    ax.set_xlabel("t (s)")
    ax.set_ylabel(r"$\Vert e_A \Vert$ (mixed units of the task vector)")
    ax.set_yscale("log")
    ax.set_title("Formation error norm" + (" with disturbances (Fig. B.3)" if disturbances else " (Fig. B.2)"))
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    files.append(out / f"error_norm{suffix}.png")
    fig.savefig(files[-1], dpi=110)
    plt.close(fig)
    for r in runs:
        data = log_reader.read(r.log, topics=[f"/plant_{a}" for a in AGENTS])
        fig = plt.figure(figsize=(11, 4.8))
        ax3 = fig.add_subplot(1, 2, 1, projection="3d")
        top = fig.add_subplot(1, 2, 2)
        for i, a in enumerate(AGENTS):
            p = np.array([[m["x"], m["y"], m["z"]] for m in data[f"/plant_{a}"]], dtype=float)
            ax3.plot(p[:, 0], p[:, 1], p[:, 2], color=f"C{i}", label=LABEL[a])
            top.plot(p[:, 0], p[:, 1], color=f"C{i}", label=LABEL[a])
            for axis, pt in ((ax3, p[0]), (top, p[0])):
                axis.scatter(*(pt if axis is ax3 else pt[:2]), color=f"C{i}", marker="o", s=15)
        ax3.set_xlabel("x (m)")
        ax3.set_ylabel("y (m)")
        ax3.set_zlabel("z (m)")
        top.set_xlabel("x (m)")
        top.set_ylabel("y (m)")
        top.grid(True, alpha=0.3)
        top.legend(fontsize=8)
        fig.suptitle(f"UAV paths, {r.controller}{', with disturbances' if disturbances else ''} (Fig. B.5)")
        fig.tight_layout()
        files.append(out / f"paths_{r.controller}{suffix}.png")
        fig.savefig(files[-1], dpi=110)
        plt.close(fig)
    return files

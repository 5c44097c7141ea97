"""Foxglove layouts for tiltload logs: the loop's (3D replay, tracking, estimator bounds, actuators) and the
formation's (three UAVs in one 3D panel, error norms, each UAV against its references).

Built with foxglove-sdk's layout classes; `tiltload layout [--formation] OUT.json` writes one, and
docs/foxglove_layout.json, docs/foxglove_layout_formation.json are those files (tests keep them equal and
check every plotted path exists in a run's log). In Foxglove: open the .mcap, then Layouts -> Import from file.
"""

from __future__ import annotations

import json
from pathlib import Path

PATHS = {
    "tracking x, y, z (m)": [("/plant.x", "x"), ("/scenario.x_ref", "x_ref"), ("/plant.y", "y"), ("/scenario.y_ref", "y_ref"),
                             ("/plant.z", "z"), ("/scenario.z_ref", "z_ref")],
    "estimate of x with its bounds (m)": [("/plant.x", "x (true)"), ("/controller.est_x", "estimate"),
                                          ("/controller.est_x_lo", "lower bound"), ("/controller.est_x_hi", "upper bound")],
    "estimate of z with its bounds (m)": [("/plant.z", "z (true)"), ("/controller.est_z", "estimate"),
                                          ("/controller.est_z_lo", "lower bound"), ("/controller.est_z_hi", "upper bound")],
    "thrusts (N)": [("/controller.f_R", "f_R"), ("/controller.f_L", "f_L"), ("/plant.f_R_applied", "f_R applied"),
                    ("/plant.f_L_applied", "f_L applied")],
    "servo torques (N m)": [("/controller.tau_R", "tau_R"), ("/controller.tau_L", "tau_L")],
    "load attitude and yaw (rad)": [("/plant.phi", "phi"), ("/plant.theta", "theta"), ("/plant.psi", "psi")],
}


FORMATION_PATHS = {
    "formation error norms": [("/formation.error_norm", "||e_A||"), ("/formation.error_leader", "leader"),
                              ("/formation.error_relative", "relative pose"), ("/formation.error_absolute", "absolute pose")],
    **{f"UAV {a}: x, y, z and references (m)": [(f"/plant_{a}.{c}", c) for c in "xyz"]
       + [(f"/formation.{a}_{c}_ref", f"{c} ref") for c in "xyz"] for a in ("sigma", "zeta", "tau")},
    "thrusts of the leader (N)": [("/tracker_sigma.f_R", "f_R"), ("/tracker_sigma.f_L", "f_L")],
}
FORMATION_SCENES = ("/scene/plant_sigma", "/scene/plant_zeta", "/scene/plant_tau")


def layout_json(formation: bool = False) -> str:
    from foxglove import layouts as L

    def plot(title, series):
        return L.PlotPanel(title=title, config=L.PlotConfig(paths=[L.PlotSeries(value=v, label=lab, enabled=True)
                                                                   for v, lab in series], show_legend=True))

    paths = FORMATION_PATHS if formation else PATHS
    plots = [L.SplitItem(content=plot(title, series)) for title, series in paths.items()]
    topics = FORMATION_SCENES if formation else ("/scene",)
    scene = L.ThreeDeePanel(title="three UAVs in formation" if formation else "UAV, rod and load", config=L.ThreeDeeConfig(
        topics={t: L.BaseRendererSceneUpdateTopicSettings(visible=True) for t in topics}))
    content = L.SplitContainer(direction="row", items=[
        L.SplitItem(proportion=1, content=scene),
        L.SplitItem(proportion=1, content=L.SplitContainer(direction="column", items=plots[:3])),
        L.SplitItem(proportion=1, content=L.SplitContainer(direction="column", items=plots[3:]))])
    return json.dumps(json.loads(L.Layout(content=content).to_json()), indent=1, sort_keys=True) + "\n"


def write(path: Path, formation: bool = False) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(layout_json(formation))
    return path

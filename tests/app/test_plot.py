"""The figures of a run: every axis says its unit, the ZSE's norm is typeset, the UAV alone's figures too."""

from __future__ import annotations

import re

import matplotlib.pyplot as plt
import pytest
from support import DATA
from tiltload.master.app.views.plot import figures, unit
from tiltload.master.engine.log import reader as log_reader

UNIT = re.compile(r"\((m|rad|m/s|rad/s|N|N m|s|[^()]*units[^()]*)\)$")


def _check(data) -> dict[str, object]:
    made = dict(figures(data))
    for name, fig in made.items():
        for ax in fig.axes:
            labels = [ax.get_xlabel(), ax.get_ylabel(), *([ax.get_zlabel()] if ax.name == "3d" else [])]
            if ax.name != "3d":
                labels = labels[1:]  # shared time axes: checked below, on the bottom row
            for label in labels:
                assert UNIT.search(label), (name, label)
            assert "‖" not in label or label.startswith("$"), (name, label)  # a norm is mathtext, not literal
        bottom = [ax for ax in fig.axes if ax.name != "3d" and ax.get_subplotspec().is_last_row()]
        for ax in bottom:
            assert ax.get_xlabel() == "t (s)", (name, ax.get_ylabel())
        plt.close(fig)
    return made


@pytest.mark.slow
def test_every_axis_of_the_loop_s_figures_has_its_unit():
    made = _check(log_reader.read(DATA / "json_log_v0.mcap"))  # a ZSE loop: all seven kinds
    assert set(made) == {"trajectory3d", "tracking_error", "disturbances", "remaining_dof", "actuators",
                         "estimation_error", "zse_frobenius"}


@pytest.mark.slow
def test_the_uav_alone_s_figures_have_units_too(uav_log):
    made = _check(log_reader.read(uav_log))
    assert "estimation_error_rest" in made


@pytest.fixture(scope="module")
def uav_log(tmp_path_factory):
    from support import ROOT
    from tiltload.master.app.cli import main
    from tiltload.master.app.loop.fmus import build_all

    out = tmp_path_factory.mktemp("uav")
    build_all(ROOT / "fmus", progress=lambda *_: None, vehicles=("uav",))
    assert main(["run", "--vehicle", "uav", "--stop-time", "1.2", "--fmus", str(ROOT / "fmus"), "--out", str(out),
                 "--quiet", "--no-plots", "--name", "uav"]) == 0
    return out / "uav.mcap"


def test_units_by_name():
    assert [unit(n) for n in ("x", "psi", "z_dot", "gamma_1_dot", "f_R", "tau_L", "y_B")] == \
        ["m", "rad", "m/s", "rad/s", "N", "N m", "m"]


def test_every_figure_is_titled_with_its_case():
    from tiltload.master.app.views.plot import case_title

    case = case_title({"vehicle": "load", "scenario": "zse", "trajectory": "1", "controller": "mixed", "seed": "7",
                       "delay": "True", "gusts": "False", "fmi": "2"})
    assert case == "UAV with load, scenario zse, trajectory 1, controller mixed, seed 7, 1-tick delay, no gusts"
    made = dict(figures(log_reader.read(DATA / "json_log_v0.mcap"), case))
    for name, fig in made.items():
        assert fig._suptitle is not None and case in fig._suptitle.get_text(), name
        plt.close(fig)


def test_a_system_file_s_run_is_titled_by_its_file():
    from tiltload.master.app.views.plot import case_title

    assert case_title({"system": "/tmp/x/loop.ssp", "faults": "runs/f.yaml"}) == "system loop.ssp, faults f.yaml"


def test_limits_far_from_the_data_are_named_not_drawn():
    import numpy as np
    from tiltload.master.app.views.plot import limit_view

    torque = np.array([-0.018, 0.045, 0.0, 0.01])
    (lo, hi), shown, far = limit_view(torque, (-2.0, 2.0))
    assert shown == [] and far == [-2.0, 2.0]
    assert -0.03 < lo < -0.018 and 0.045 < hi < 0.06  # the trace fills the axis
    (lo, hi), shown, far = limit_view(np.array([-1.9, 1.5]), (-2.0, 2.0))  # near both limits: both drawn, both seen
    assert shown == [-2.0, 2.0] and far == [] and lo < -2.0 and hi > 2.0
    (lo, hi), shown, far = limit_view(np.array([9.5, 13.0]), (0.0, 30.0))
    assert shown == [] and 9.0 < lo < 9.5 and 13.0 < hi < 14.0
    _, shown, far = limit_view(np.array([24.0, 29.0]), (0.0, 30.0))  # thrust near its top: that limit drawn
    assert shown == [30.0] and far == [0.0]


@pytest.mark.slow
def test_the_actuator_figure_is_scaled_to_the_torques_not_their_limits():
    made = dict(figures(log_reader.read(DATA / "json_log_v0.mcap")))
    fig = made["actuators"]
    tau = next(ax for ax in fig.axes if ax.get_ylabel().startswith("tau_R"))
    lo, hi = tau.get_ylim()
    assert hi - lo < 0.2  # the torques of this log stay within 0.05 N m; ±2 N m lines would flatten them
    assert any("off the scale" in t.get_text() for t in tau.texts)
    for f in made.values():
        plt.close(f)

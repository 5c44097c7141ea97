"""The figures of a run: every axis says its unit, the ZSE's norm is typeset, the UAV alone's figures too."""

from __future__ import annotations

import re

import matplotlib.pyplot as plt
import pytest
from support import DATA
from tiltload.master.app.plot import figures, unit
from tiltload.master.engine import log_reader

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


def test_every_axis_of_the_loop_s_figures_has_its_unit():
    made = _check(log_reader.read(DATA / "json_log_v0.mcap"))  # a ZSE loop: all seven kinds
    assert set(made) == {"trajectory3d", "tracking_error", "disturbances", "remaining_dof", "actuators",
                         "estimation_error", "zse_frobenius"}


def test_the_uav_alone_s_figures_have_units_too(uav_log):
    made = _check(log_reader.read(uav_log))
    assert "estimation_error_rest" in made


@pytest.fixture(scope="module")
def uav_log(tmp_path_factory):
    from support import ROOT
    from tiltload.master.app.cli import main
    from tiltload.master.app.fmus import build_all

    out = tmp_path_factory.mktemp("uav")
    build_all(ROOT / "fmus", progress=lambda *_: None, vehicles=("uav",))
    assert main(["run", "--vehicle", "uav", "--stop-time", "1.2", "--fmus", str(ROOT / "fmus"), "--out", str(out),
                 "--quiet", "--no-plots", "--name", "uav"]) == 0
    return out / "uav.mcap"


def test_units_by_name():
    assert [unit(n) for n in ("x", "psi", "z_dot", "gamma_1_dot", "f_R", "tau_L", "y_B")] == \
        ["m", "rad", "m/s", "rad/s", "N", "N m", "m"]

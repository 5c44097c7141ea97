"""The controller against tiltload's loop: its metrics equal the recorded baselines', and stay within limits."""

from pathlib import Path

import pytest
from tiltload.testing import assert_metrics_below

CONTROLLER = Path(__file__).parents[1] / "controller" / "hover_lqr.py"


@pytest.mark.tiltload_cases(scenario="fsi", trajectory=1, seed=[1, 2], stop_time=3)
def test_the_controller_matches_its_baseline(tiltload_run, tiltload_case, tiltload_baseline):
    result = tiltload_run(controller=CONTROLLER, **tiltload_case)
    tiltload_baseline.check(result)


def test_the_controller_tracks_the_circle_closely(tiltload_run):
    result = tiltload_run(controller=CONTROLLER, scenario="fsi", trajectory=1, stop_time=3)
    assert_metrics_below(result, {"ISE(x)": 0.5, "ISE(y)": 0.5, "ISE(z)": 0.5})

"""Helpers of the test suite: FMU sessions on FMPy (fmi2_session), independent references (physics_oracle,
trajectory_oracle), a third-party controller FMU, C and Python hosts (hosts/), old logs (data/)."""

from __future__ import annotations

from pathlib import Path

from tiltload.plant_fmu.interface import STATE_NAMES

ROOT = Path(__file__).resolve().parents[2]  # the repository
HOSTS = Path(__file__).parent / "hosts"
DATA = Path(__file__).parent / "data"
T = 0.012  # the loop's tick
NATIVE = ("TiltloadPlant", "TiltloadSensors", "TiltloadScenario")  # the FMUs without designs inside
# a state far from the trim: every joint and rate nonzero, to exercise the whole model
TUMBLE = dict(zip(STATE_NAMES, [0.1, -0.2, 0.3, 0.3, -0.2, 0.4, 0.25, -0.3, 0.2, -0.15,
                                0.2, -0.1, 0.3, 0.4, -0.3, 0.5, -0.4, 0.3, 0.35, -0.25]))

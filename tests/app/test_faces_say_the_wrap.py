"""A class's .py file wrapped on the fly is said in the same words by every face that takes one: run's
`--controller F: wrapped as ...`, b2b's, and a campaign's or a search's spec naming it (base.controllers,
base.controller), each once before its runs."""

from __future__ import annotations

import pytest
import tiltload as tl

HOLD = """import numpy as np


class Hold:
    inputs = ["exact_z", "z_ref", "exact_z_dot"]

    def __init__(self):
        self.kp = 4.0

    def step(self, t, inputs):
        f = 10.2 + self.kp * (inputs["z_ref"] - inputs["exact_z"]) - 2.5 * inputs["exact_z_dot"]
        return float(np.clip(f, 0, 30)), float(np.clip(f, 0, 30)), 0.0, 0.0
"""
NATIVE = "hold.py: wrapped as a native C FMU (traced from plain numpy)"


@pytest.mark.slow
def test_a_campaign_and_a_search_say_the_class_file_they_wrapped(fmus, tmp_path, monkeypatch):
    monkeypatch.setenv("TILTLOAD_CACHE", str(tmp_path / "cache"))
    (tmp_path / "hold.py").write_text(HOLD)
    campaign = tmp_path / "c.toml"
    campaign.write_text('name = "c"\n[base]\nscenario = "fsi"\ntrajectory = 1\ncontrollers = ["hold.py"]\n'
                        "stop_time = 0.5\n[vary]\nseeds = [1]\n")
    said: list[str] = []
    tl.campaign(campaign, workers=1, fmus=fmus, out=tmp_path / "c", progress=said.append)
    assert said.count(f"base.controllers {NATIVE}") == 1, said
    search = tmp_path / "f.toml"
    search.write_text('name = "f"\n[base]\nscenario = "fsi"\ntrajectory = 1\ncontroller = "hold.py"\nstop_time = 0.5\n'
                      '[[requirements]]\nname = "z"\nformula = "always (abs(plant.z) < 5)"\n'
                      '[[search]]\nname = "m"\ntarget = "plant.m_L"\nrange = [0.1, 0.3]\n[budget]\nsimulations = 1\n')
    said.clear()
    tl.falsify(search, workers=1, fmus=fmus, out=tmp_path / "f", progress=said.append)
    assert said.count(f"base.controller {NATIVE}") == 1, said

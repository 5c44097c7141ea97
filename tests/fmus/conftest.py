"""The FMI 3.0 FMUs with clocks and the Scheduled Execution controller, built once for the tests of this folder."""

from __future__ import annotations

from pathlib import Path

import pytest


@pytest.fixture(scope="module")
def fmi3_set(fmi3_fmus):
    """The FMI 3.0 folder with the clocked variants and the Scheduled Execution controller built too."""
    from tiltload.master.app.loop.fmus import build_all, build_many, scheduled_recipes

    folder = fmi3_fmus["TiltloadPlant"].parent
    build_all(folder, progress=lambda *_: None, fmi_version=3, clocked=True)
    build_many(scheduled_recipes(("load",)), folder, progress=lambda *_: None, fmi_version=3)
    return folder


@pytest.fixture(scope="module")
def se_fmu(fmi3_set) -> Path:
    return fmi3_set / "TiltloadControllerSE.fmu"

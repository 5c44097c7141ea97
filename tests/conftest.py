"""Shared fixtures: the plant FMU is built once per session (only if missing or stale)."""

from __future__ import annotations

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="session")
def plant_fmu() -> Path:
    from tiltload.master.engine.pythonfmu_guard import pin
    from tiltload.native_fmu.build import build
    from tiltload.plant_fmu.build import recipe

    path = build(recipe(), ROOT / "fmus").path
    pin(path)  # FMPy unloads FMUs after each run; pythonfmu must not be fully unloaded
    return path


@pytest.fixture(scope="session")
def pipeline_fmus() -> dict[str, Path]:
    """All four FMUs (the controller's first build synthesizes the mixed design: about 90 s, then cached)."""
    from tiltload.master.app.fmus import build_all
    from tiltload.master.engine.pythonfmu_guard import pin

    paths = {r.path.stem: r.path for r in build_all(ROOT / "fmus", progress=lambda *_: None)}
    for path in paths.values():
        pin(path)
    return paths


def pytest_sessionfinish(session, exitstatus):
    session.config._tiltload_exit = int(exitstatus)


@pytest.hookimpl(trylast=True)
def pytest_unconfigure(config):
    """After the report: a process that loaded pythonfmu FMUs (wrapped controllers) leaves without the interpreter
    shutdown those can crash (master/pythonfmu_guard.py); everything else exits normally."""
    from tiltload.master.engine.pythonfmu_guard import exit_now, pinned

    if pinned():
        exit_now(getattr(config, "_tiltload_exit", 0))

"""Shared fixtures: the FMUs are built once per session (only if missing or stale)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).parent))  # the helpers package, tests/support
LIBCOSIMPY = "libcosimpy==0.0.6"


@pytest.fixture(scope="session")
def plant_fmu() -> Path:
    from tiltload.master.engine.fmi.pythonfmu_guard import pin
    from tiltload.native_fmu.build import build
    from tiltload.plant_fmu.build import recipe

    path = build(recipe(), ROOT / "fmus").path
    pin(path)  # FMPy unloads FMUs after each run; pythonfmu must not be fully unloaded
    return path


@pytest.fixture(scope="session")
def pipeline_fmus() -> dict[str, Path]:
    """All four FMUs (the controller's first build synthesizes the mixed designs, then cached)."""
    from tiltload.master.app.loop.fmus import build_all
    from tiltload.master.engine.fmi.pythonfmu_guard import pin

    paths = {r.path.stem: r.path for r in build_all(ROOT / "fmus", progress=lambda *_: None)}
    for path in paths.values():
        pin(path)
    return paths


@pytest.fixture(scope="session")
def fmi3_fmus() -> dict[str, Path]:
    """The loop's FMUs as FMI 3.0 co-simulation FMUs (fmus/fmi3/), by file stem."""
    from tiltload.master.app.loop.fmus import build_all, fmu_folder

    results = build_all(fmu_folder(ROOT / "fmus", 3), progress=lambda *_: None, fmi_version=3)
    return {r.path.stem: r.path for r in results}


@pytest.fixture(scope="session")
def fmus(pipeline_fmus) -> Path:
    """The folder of the loop's FMUs."""
    return pipeline_fmus["TiltloadPlant"].parent


@pytest.fixture(scope="module")
def native(pipeline_fmus) -> dict[str, Path]:
    """The plant, sensor and scenario FMUs (no designs inside)."""
    from support import NATIVE

    return {name: pipeline_fmus[name] for name in NATIVE}


@pytest.fixture
def opened():
    """open_(fmu path, instance name) -> an FMPy session, closed after the test."""
    from support.fmi2_session import Session

    sessions = []

    def open_(path, instance="fmu"):
        s = Session(path, instance)
        sessions.append(s)
        return s
    yield open_
    for s in sessions:
        s.close()


@pytest.fixture(scope="session")
def libcosim_python() -> Path:
    """A virtual environment with libcosimpy and nothing else (no numpy), kept in the tiltload cache."""
    from tiltload.controller_fmu.design.cache import cache_root

    venv = cache_root() / "venvs" / LIBCOSIMPY.replace("==", "-")
    python = venv / "bin" / "python"
    if not (venv / "ready").exists():
        shutil.rmtree(venv, ignore_errors=True)
        subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
        subprocess.run([str(python), "-m", "pip", "install", "--quiet", "--disable-pip-version-check", LIBCOSIMPY],
                       check=True, timeout=600)
        (venv / "ready").write_text(LIBCOSIMPY)
    assert subprocess.run([str(python), "-c", "import numpy"], capture_output=True).returncode != 0
    return python


def pytest_sessionfinish(session, exitstatus):
    session.config._tiltload_exit = int(exitstatus)


@pytest.hookimpl(trylast=True)
def pytest_unconfigure(config):
    """After the report: a process that loaded pythonfmu FMUs (wrapped controllers) leaves without the interpreter
    shutdown those can crash (engine/fmi/pythonfmu_guard.py); everything else exits normally."""
    from tiltload.master.engine.fmi.pythonfmu_guard import exit_now, pinned

    if pinned():
        exit_now(getattr(config, "_tiltload_exit", 0))


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    """In CI (CI=true) a skip is a failure: .ci/run installs every tool and package the tests use, so a test that
    skips there hides a missing install step. On a developer's machine a missing cross compiler still only skips."""
    outcome = yield
    report = outcome.get_result()
    if os.environ.get("CI", "").lower() in ("1", "true", "yes") and report.skipped and not hasattr(report, "wasxfail"):
        reason = report.longrepr[2] if isinstance(report.longrepr, tuple) else str(report.longrepr)
        report.outcome = "failed"
        report.longrepr = f"skipped in CI, where nothing may be missing: {reason}"

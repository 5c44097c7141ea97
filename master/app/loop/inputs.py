"""The scenario's files (trajectories, wind) read through the engine's one input layer (engine.user_files).

The scenario package interprets them (scenario_fmu.files.Reader); this is the reader it is handed, and the two
entry points the application uses. A problem in the file is one line naming it (a UserFileError or ScenarioFileError).
"""

from __future__ import annotations

from pathlib import Path

from ....scenario_fmu import choice, wind
from ...engine import user_files


class _Files:
    """scenario_fmu.files.Reader on engine.user_files."""

    def table(self, path: Path) -> list[tuple[int, list[str]]]:
        return user_files.read_csv(path)

    def document(self, path: Path) -> object:
        return user_files.read_document(path)


READER = _Files()


def trajectory(value, base: Path | None = None) -> choice.Trajectory:
    """A Trajectory from a Trajectory, a thesis code, a built-in's text or a trajectory file (scenario_fmu.choice)."""
    return choice.as_trajectory(value, base, READER)


def read_wind(path: Path) -> dict:
    """The scenario FMU's wind parameters of a wind file (scenario_fmu.wind.read_wind)."""
    return wind.read_wind(Path(path), READER)

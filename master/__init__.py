"""The master: a generic FMI co-simulation engine (engine/) and the tiltload application on top of it (app/).

The application imports the engine, never the reverse; the engine imports nothing of the FMU
packages (docs/architecture.md; enforced by import-linter, pyproject.toml).
"""

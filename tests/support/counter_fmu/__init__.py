"""A counter FMU that ends the simulation at a given count, built with the project's native FMU toolkit (FMI 2.0 and
3.0): count + 1 a step, x = count * gain, y = u; at count == limit it asks the importer to terminate (FMI 3.0:
terminateSimulation from the step that reached it; FMI 2.0: the next step refused with fmi2Discard and fmi2Terminated)."""

from __future__ import annotations

from pathlib import Path

from tiltload.native_fmu.build import Prepared, Recipe, build
from tiltload.native_fmu.compile import NativeSources, choose, host_platform, toolchain
from tiltload.native_fmu.variables import FmuDefinition, Variable

HERE = Path(__file__).parent
SOURCES = [HERE / "counter_model.c", HERE / "counter_model.h"]


def _prepare(folder: Path, progress) -> Prepared:
    variables = [Variable("count", "Integer", "output", 0, "steps taken"),
                 Variable("x", "Real", "output", 0.0, "count * gain"),
                 Variable("y", "Real", "output", 0.0, "u, fed through"),
                 Variable("u", "Real", "input", 0.0, "an input fed through to y"),
                 Variable("gain", "Real", "parameter", 0.5, "x per count"),
                 Variable("limit", "Integer", "parameter", 5, "the count at which it ends the simulation"),
                 Variable("first", "Integer", "parameter", 0, "the count after initialization")]
    definition = FmuDefinition("TiltloadTestCounter", "a counter that ends the simulation", variables, "counter_model.h",
                               (0.0, 1.0, 0.1))
    return Prepared(definition, NativeSources(SOURCES))


def _built(recipe: Recipe, dest: Path, fmi_version: int) -> Path:
    """A recipe's FMU built into dest, for this machine's platform only."""
    return build(recipe, dest, progress=lambda *_: None, toolchains=(toolchain(host_platform()),),
                 fmi_version=fmi_version).path


def counter_fmu(dest: Path, fmi_version: int = 2) -> Path:
    """The counter FMU built into dest (for this machine's platform only)."""
    return _built(Recipe("TiltloadTestCounter.fmu", tuple(SOURCES), ("counter",), _prepare), dest, fmi_version)


CLOCK_SOURCES = [HERE / "clock_model.c", HERE / "clock_model.h"]


def _prepare_clock(folder: Path, progress) -> Prepared:
    variables = [Variable("now", "Real", "output", 0.0, "the time its outputs belong to"),
                 Variable("y", "Real", "output", 0.0, "u + now"),
                 Variable("tenths", "Integer", "output", 0, "now in whole tenths of a second"),
                 Variable("steps", "Integer", "output", 0, "steps taken"),
                 Variable("u", "Real", "input", 0.0, "an input fed through to y")]
    definition = FmuDefinition("TiltloadTestClock", "a clock that reads the FMU's time", variables, "clock_model.h",
                               (0.0, 1.0, 0.1))
    return Prepared(definition, NativeSources(CLOCK_SOURCES))


def clock_fmu(dest: Path, fmi_version: int = 2) -> Path:
    """A clock FMU (clock_model.c: now, tenths, steps, y = u + now) built into dest, for this machine's platform."""
    return _built(Recipe("TiltloadTestClock.fmu", tuple(CLOCK_SOURCES), ("clock",), _prepare_clock), dest, fmi_version)


__all__ = ["counter_fmu", "clock_fmu", "choose"]

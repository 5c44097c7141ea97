"""A spec file (TOML or YAML) of a case set, campaign or search alike: its bounded read, the schema of the base case
every run shares, the base's faults checked; a problem is a SpecError naming the file and the field."""

from __future__ import annotations

from pathlib import Path

from ..loop.defaults import SCENARIOS
from .targets import TARGET_PATTERN

NAME = {"type": "string", "pattern": "^[A-Za-z0-9_.-]+$"}  # a spec's name: it names files and folders
SEED = {"type": "integer", "minimum": 0, "maximum": 2147483647}
# the base case: what every run of a campaign or a search shares (a campaign adds controllers and snapshot; a search a
# controller and a seed)
BASE_PROPERTIES = {
    "scenario": {"enum": list(SCENARIOS)},
    "trajectory": {"anyOf": [{"enum": [0, 1, 2]}, {"type": "string", "minLength": 1}]},
    "wind": {"type": "string", "minLength": 1},
    "allow_infeasible": {"type": "boolean"},
    "max_tilt": {"type": "number", "exclusiveMinimum": 0, "maximum": 180},
    "stop_time": {"type": "number", "exclusiveMinimum": 0, "maximum": 3600},
    "gusts": {"type": "boolean"},
    "parameters": {"type": "object", "propertyNames": {"pattern": r"^[A-Za-z_]\w*\.[A-Za-z_]\w*$"},
                   "additionalProperties": {"type": ["number", "string", "boolean"]}},
    "faults": {"type": "array"},
}
TARGET = {"type": "string", "pattern": TARGET_PATTERN}


class SpecError(ValueError):
    """A campaign or falsification spec that cannot be run; the message names the file and the field."""


def read_spec_file(path: Path) -> dict:
    from ...engine.user_files import UserFileError, read_toml, read_yaml, regular_file

    try:
        regular_file(path, "spec")
    except UserFileError as err:
        raise SpecError(str(err)) from None
    if path.suffix not in (".toml", ".yaml", ".yml"):
        raise SpecError(f"{path}: a campaign spec is a .toml, .yaml or .yml file")
    try:
        data = read_toml(path) if path.suffix == ".toml" else read_yaml(path)
    except UserFileError as err:
        raise SpecError(str(err)) from None
    if not isinstance(data, dict):
        raise SpecError(f"{path}: a campaign spec is a mapping of name, base, vary, keep")
    return data


def checked_faults(base: dict, targets: list[tuple[str, str]], path: Path) -> list:
    """base.faults parsed as a fault file is (their JSON form returned); each (where, target) of the varied targets
    that names a fault names one base.faults has."""
    from ...engine.faults.parse import parse
    from ...engine.faults.schedule import FaultError
    from .targets import fault_field

    faults = base.get("faults", [])
    try:
        parse(faults, f"{path}: base.faults")
    except FaultError as err:
        raise SpecError(str(err)) from None
    for where, target in targets:
        named = fault_field(target)
        if named is not None and named[0] >= len(faults):
            raise SpecError(f"{path}: {where}: {target} names a fault base.faults does not have")
    return faults

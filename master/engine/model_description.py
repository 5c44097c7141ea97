"""What the engine reads of an FMU before loading it: its model description, and values checked against it."""

from __future__ import annotations

import math
import zipfile
from pathlib import Path

from fmpy import read_model_description

from .errors import DescriptionError


def read_fmu(path: Path, instance: str):
    """Model description of a co-simulation FMU, or a DescriptionError saying what the file is not."""
    path = Path(path)
    if not path.is_file():
        raise DescriptionError(f"{instance}: FMU file {path} does not exist")
    if not zipfile.is_zipfile(path):
        raise DescriptionError(f"{instance}: {path} is not an FMU (not a zip archive)")
    try:
        md = read_model_description(str(path), validate=False)
    except Exception as err:  # fmpy raises various types for a broken modelDescription.xml
        raise DescriptionError(f"{instance}: {path} is not a valid FMU ({err})") from None
    if md.fmiVersion != "2.0":
        raise DescriptionError(f"{instance}: {path} is FMI {md.fmiVersion}; only FMI 2.0 co-simulation is supported")
    if md.coSimulation is None:
        raise DescriptionError(f"{instance}: {path} is a model-exchange-only FMU; a co-simulation FMU is needed")
    return md


def checked_value(instance: str, v, key: str, value):
    """A parameter (or unconnected input) value converted to the variable's FMI type, or a DescriptionError
    naming it: unknown or unsettable variable, wrong kind, non-finite, outside the declared min/max or int32."""
    if v is None:
        raise DescriptionError(f"{instance} has no variable '{key}' to set")
    if v.causality not in ("parameter", "input") or v.variability == "constant":
        raise DescriptionError(f"{instance}.{key} is a {v.causality} ({v.variability}); only parameters and inputs can be set")
    where = f"{instance}.{key} = {value!r}"
    if v.type in ("Real", "Integer"):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise DescriptionError(f"{where}: must be a number")
        if not math.isfinite(value):
            raise DescriptionError(f"{where}: must be finite")
        if v.type == "Integer":
            if value != int(value) or not -2**31 <= value < 2**31:
                raise DescriptionError(f"{where}: must be a whole number that fits 32 bits")
            value = int(value)
        else:
            value = float(value)
        lo, hi = (None if b is None else float(b) for b in (v.min, v.max))
        if (lo is not None and value < lo) or (hi is not None and value > hi):
            raise DescriptionError(f"{where}: outside its declared range [{lo if lo is not None else '-inf'}, "
                                   f"{hi if hi is not None else 'inf'}]")
        return value
    if v.type == "Boolean":
        if isinstance(value, bool) or value in (0, 1):
            return bool(value)
        raise DescriptionError(f"{where}: must be true or false")
    return str(value)

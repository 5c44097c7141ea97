"""What a run ran, for a log and a baseline to say what changed: every instance's FMU (file, SHA-256, model name, GUID or
instantiation token), its parameters as the run set them (the model description's start values, then the system's
settings), and the units of its outputs. Flat text records (MCAP metadata): "controller.sha256", "controller.param.kp".
"""

from __future__ import annotations

import hashlib
import os
import re
import zipfile
from pathlib import Path

_DIGESTS: dict[tuple[str, int, int], str] = {}  # (path, size, mtime) -> SHA-256: a campaign's restarts hash nothing again


def fmu_digest(path: Path) -> str:
    """The FMU's SHA-256 (hex), computed once per file version in this process."""
    from ..fmi.fmu_cache import digest

    st = os.stat(path)
    key = (str(Path(path).resolve()), st.st_size, st.st_mtime_ns)
    if key not in _DIGESTS:
        _DIGESTS[key] = digest(path)
    return _DIGESTS[key]


_STAMPS = re.compile(rb'\b(guid|instantiationToken|generationDateAndTime)="[^"]*"')


def content_digest(path: Path) -> str:
    """SHA-256 of an FMU's members (names and bytes, in name order) with its build stamps blanked (the model
    description's GUID or instantiation token and generation time): two builds of the same sources that differ only by
    those (a pythonfmu wrap stamps both anew each time) have the same content digest."""
    st = os.stat(path)
    key = ("content:" + str(Path(path).resolve()), st.st_size, st.st_mtime_ns)
    if key not in _DIGESTS:
        h = hashlib.sha256()
        with zipfile.ZipFile(path) as z:
            for name in sorted(z.namelist()):
                data = z.read(name)
                if name == "modelDescription.xml":
                    data = _STAMPS.sub(rb'\1=""', data)
                h.update(name.encode() + b"\0" + len(data).to_bytes(8, "little") + data)
        _DIGESTS[key] = h.hexdigest()
    return _DIGESTS[key]


def _text(value: object) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    return str(value)


def _start_text(v) -> str | None:
    """A variable's start value as the parameter's text ("1.5", "true"), None without one."""
    start = getattr(v, "start", None)
    if start is None:
        return None
    if v.type in ("Real", "Float64", "Float32"):
        try:
            return repr(float(start))
        except ValueError:
            return str(start)
    return str(start).lower() if v.type == "Boolean" else str(start)


def fmus_record(instances, model_descriptions: dict) -> dict[str, str]:
    """instances: the system's (name, fmu, parameters); model_descriptions: {name: FMPy model description}."""
    out: dict[str, str] = {}
    for spec in instances:
        md = model_descriptions[spec.name]
        path = Path(spec.fmu)
        out[f"{spec.name}.fmu"] = path.name
        out[f"{spec.name}.sha256"] = fmu_digest(path) if path.is_file() else ""
        try:
            out[f"{spec.name}.content"] = content_digest(path) if path.is_file() else ""
        except (OSError, zipfile.BadZipFile):  # FMPy read it, so it is an archive; a race with a rebuild says nothing
            out[f"{spec.name}.content"] = ""
        if path.is_file() and (source := wrapped_source(path)):
            out[f"{spec.name}.source"] = source
        out[f"{spec.name}.model"] = str(md.modelName)
        out[f"{spec.name}.guid"] = str(getattr(md, "guid", None) or getattr(md, "instantiationToken", "") or "")
        for v in md.modelVariables:
            if v.causality in ("parameter", "structuralParameter"):
                start = _start_text(v)
                if start is not None:
                    out[f"{spec.name}.param.{v.name}"] = start
        variables = {v.name: v for v in md.modelVariables}
        for name, value in spec.parameters.items():
            v = variables.get(name)
            real = v is not None and v.type in ("Real", "Float64", "Float32")
            try:  # a setting given as text ("0.05") reads as the start value's text does
                out[f"{spec.name}.param.{name}"] = repr(float(value)) if real and not isinstance(value, bool) else _text(value)
            except (TypeError, ValueError):
                out[f"{spec.name}.param.{name}"] = _text(value)
    return out


SOURCE_LIMIT = 65_536  # characters of a wrapped class's source kept in a record (a controller class is a few thousand)


def wrapped_source(path: Path) -> str:
    """The source text an FMU was wrapped from, where its build record carries one (a build_info.json under resources/
    with a "source": what `tiltload wrap` writes, either route), so a comparison can say which lines changed; else ''."""
    import json

    try:
        with zipfile.ZipFile(path) as z:
            for name in sorted(n for n in z.namelist() if n.startswith("resources/") and n.endswith("build_info.json")):
                info = json.loads(z.read(name))
                if isinstance(info, dict) and isinstance(info.get("source"), str):
                    return info["source"][:SOURCE_LIMIT]
    except (OSError, zipfile.BadZipFile, ValueError):
        pass
    return ""


def units_record(instances, model_descriptions: dict) -> dict[str, str]:
    """{"instance.output": unit} for every output whose model description gives a unit."""
    out = {}
    for spec in instances:
        for v in model_descriptions[spec.name].modelVariables:
            unit = getattr(v, "unit", None) or getattr(getattr(v, "declaredType", None), "unit", None)
            if v.causality == "output" and unit:
                out[f"{spec.name}.{v.name}"] = str(unit)
    return out


def parameters(record: dict[str, str], instance: str) -> dict[str, str]:
    """An instance's parameters from a fmus record: {name: value as text}."""
    prefix = f"{instance}.param."
    return {k[len(prefix):]: v for k, v in record.items() if k.startswith(prefix)}


def instance_names(record: dict[str, str]) -> list[str]:
    """The instances a fmus record names, in its order."""
    return [k[: -len(".fmu")] for k in record if k.endswith(".fmu") and ".param." not in k]

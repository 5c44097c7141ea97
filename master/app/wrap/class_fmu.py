"""A Python controller class given to the API (`tiltload.Case(controller=MyController)`) as a controller FMU: wrapped the
way `tiltload wrap` wraps it, from the class's file, and kept in the machine's cache under the digest of what decides
the build (the file, the class's declarations and parameters, the route, the FMI version, tiltload's version and its
wrapping code), so a second run, in this process or another, uses the same FMU without tracing or building again.

The route: `wrap --native` (a C FMU, native.py) when the class traces and keeps its declared parameters tunable, else
pythonfmu's (wrap.py); native=True refuses a class that cannot be traced (and fixes what its __init__ needs the number
of), native=False always takes pythonfmu's."""

from __future__ import annotations

import hashlib
import inspect
import json
import os
import shutil
import tempfile
from pathlib import Path

from ....native_fmu.build import tiltload_version
from ....native_fmu.cache import cache_root
from .wrap import WrapError, describe_class

__all__ = ["controller_fmu", "controller_fmu_of_file", "route", "wrapped_line"]


def _source(cls: object, field: str) -> Path:
    """The .py file a controller class is defined in, at its top level (the wrap imports the class from there)."""
    if not isinstance(cls, type):
        raise WrapError(f"{field}: {cls!r:.60} is not a controller class (pass the class itself, not an instance)")
    name = cls.__name__
    if not callable(getattr(cls, "step", None)):
        raise WrapError(f"{field}: {name} is not a controller class: it has no step(t, inputs) method (docs/ports.md)")
    try:
        source = inspect.getsourcefile(cls)
    except TypeError:
        source = None
    if source is None or not source.endswith(".py") or not Path(source).is_file():
        raise WrapError(f"{field}: {name} has no .py file (defined interactively?): tiltload wraps a class from its file")
    if cls.__qualname__ != name:
        raise WrapError(f"{field}: {cls.__qualname__} is not at the top level of {Path(source).name}: tiltload wraps a "
                        "class it can import from its file")
    return Path(source)


def _wrap_code() -> str:
    """The digest of the wrapping code (this folder: the tracer, the child it runs in, the slave, the C): an FMU that
    another tiltload of the same version number wrapped (one that froze a step's I/O, say) is not this one's."""
    digest = hashlib.sha256()
    for f in sorted(p for p in Path(__file__).parent.rglob("*") if p.suffix in (".py", ".c", ".h")):
        digest.update(f.name.encode() + b"\0" + f.read_bytes())
    return digest.hexdigest()


def _key(path: Path, spec: dict, native: bool | None, fmi_version: int) -> str:
    what = json.dumps({"spec": spec, "native": native, "fmi": fmi_version, "tiltload": tiltload_version(),
                       "wrap": _wrap_code()}, sort_keys=True)
    return hashlib.sha256(path.read_bytes() + b"\0" + what.encode()).hexdigest()


def _build(path: Path, name: str | None, native: bool | None, fmi_version: int, out: Path) -> Path:
    """Wrap the class (name None: the file's one class) into out: natively if it traces (or native), else with
    pythonfmu. The class's code runs in wrap's child process (sandbox.py)."""
    from .native import build_traced
    from .sandbox import traced, wrap_python

    if native is not False:
        child_spec, t = traced(path, name, fall_back=not native)
        if not isinstance(t, str) and (native or not t.fixed):  # the automatic route keeps every parameter tunable
            return build_traced(child_spec, t, path, out, fmi_version, progress=lambda line: None)
        if not isinstance(t, str):
            t = (f"{child_spec['class']}: parameter{'s' if len(t.fixed) > 1 else ''} {', '.join(t.fixed)} would be fixed in the native "
                 f"FMU ({t.why_fixed})")
        if fmi_version != 2:
            raise WrapError(f"{t}; a class that cannot be traced runs as a pythonfmu FMU, which is FMI 2.0 only "
                            "(run it with fmi=2)")
    elif fmi_version != 2:
        raise WrapError(f"{name or path.name}: a pythonfmu FMU is FMI 2.0 only (run it with fmi=2, or trace it: native=True)")
    built = wrap_python(path, out, name)  # its __init__ run once there: one that raises is refused now, not in the run
    if native is not False:
        out.with_suffix(".why").write_text(t)  # why not native: said by route() when the FMU is used
    return built


def controller_fmu(cls: type, native: bool | None = None, fmi_version: int = 2, field: str = "Case.controller") -> Path:
    """The controller FMU of cls (a class with a step method, at the top level of its .py file): from the machine's
    cache, or wrapped now and kept there. WrapError (a TraceError) says in one line what is wrong."""
    path = _source(cls, field)
    spec = describe_class(cls, path)  # the class the caller imported: its declarations, none of its code run
    key = _key(path, spec, native, fmi_version)
    target = cache_root() / "controllers" / key[:32] / f"{spec['class']}.fmu"
    if target.is_file():
        return target
    target.parent.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(dir=target.parent, prefix=".build-"))  # beside it: the rename below is atomic
    try:
        built = _build(path, spec["class"], native, fmi_version, stage / target.name)
        os.replace(built, target)
    finally:
        shutil.rmtree(stage, ignore_errors=True)
    return target


def route(fmu: Path) -> str:
    """Which route a wrapped controller FMU took, in words (and why not native, where it was kept)."""
    import zipfile

    with zipfile.ZipFile(fmu) as z:
        if "resources/slavemodule.txt" not in z.namelist():
            return "a native C FMU (traced from plain numpy)"
    why = Path(fmu).with_suffix(".why")
    return f"a pythonfmu FMU (it runs in Python{': ' + why.read_text() if why.is_file() else ''})"


def wrapped_line(source: str, fmu: Path) -> str:
    """What a face says of a class's .py file it wrapped on the fly (run, b2b, campaign, falsify alike)."""
    return f"{source}: wrapped as {route(Path(fmu))}"


def controller_fmu_of_file(path: Path, native: bool | None = None, fmi_version: int = 2,
                           field: str = "--controller", class_name: str | None = None) -> Path:
    """The controller FMU of the class in a .py file (`tiltload run --controller my_controller.py`), named after the
    file: from the machine's cache under the digest of the source (and the route, FMI version, tiltload's version and
    wrapping code), or wrapped now in wrap's child process and kept there. A module the file imports is not in the
    digest: wrap it yourself (tiltload wrap) when such a module changes. class_name: one of the file's classes (None:
    its one class), imported in the child only."""
    from ...engine.user_files import UserFileError, open_binary

    path = Path(path)
    try:
        open_binary(path, "controller").close()
    except UserFileError as err:
        raise WrapError(f"{field}: {err}") from None
    key = _key(path, {"file": path.name, **({"class": class_name} if class_name else {})}, native, fmi_version)
    target = cache_root() / "controllers" / key[:32] / f"{path.stem}{'_' + class_name if class_name else ''}.fmu"
    if target.is_file():
        return target
    target.parent.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(dir=target.parent, prefix=".build-"))
    try:
        built = _build(path.resolve(), class_name, native, fmi_version, stage / target.name)
        if built.with_suffix(".why").is_file():
            os.replace(built.with_suffix(".why"), target.with_suffix(".why"))
        os.replace(built, target)
    finally:
        shutil.rmtree(stage, ignore_errors=True)
    return target

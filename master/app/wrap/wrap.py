"""`tiltload wrap`: a user's Python controller as a controller FMU that follows the port contract.

The user writes a small class (docs/ports.md, "Your own controller in Python"):

    class MyController:
        inputs = ["exact_x", "exact_y", "exact_z", "x_ref", "y_ref", "z_ref"]   # contract names
        parameters = {"gain": 1.0}        # optional: Real FMU parameters, passed to __init__
        period = 0.012                    # optional: a whole number of 12 ms ticks

        def step(self, t, inputs):        # inputs: {name: value} at t_k
            return f_R, f_L, tau_R, tau_L

pythonfmu packages it with exactly those inputs, with the contract's types, units and start
values, and the four outputs. The FMU runs in the host's Python (pythonfmu's limits apply:
docs/native_fmus.md); everything else in tiltload is native.
"""

from __future__ import annotations

import difflib
import hashlib
import importlib.util
import inspect
import json
import math
import re
import sys
import tempfile
from pathlib import Path

from ..loop.ports import OUTPUT_UNITS, REQUIRED_OUTPUTS, contract_inputs
from . import packaging

TICK = 0.012
SLAVE = Path(__file__).with_name("wrapped_slave.py")


class WrapError(ValueError):
    """A user controller that cannot be wrapped; the message names the file, the class and the problem."""


def user_line(err: BaseException, source: Path) -> str:
    """'line N (`code`)' of the innermost frame of err in the user's file, or ''."""
    import linecache
    import traceback

    frames = [f for f in traceback.extract_tb(err.__traceback__) if Path(f.filename).resolve() == source.resolve()]
    if not frames:
        return ""
    f = frames[-1]
    code = (f.line or linecache.getline(f.filename, f.lineno)).strip()
    return f"line {f.lineno} (`{code}`)"


USER_ENDS = (Exception, SystemExit, KeyboardInterrupt)  # what the user's code may raise: sys.exit() is a refusal too


def load_module(path: Path):
    from ...engine.user_files import UserFileError, open_binary

    try:
        open_binary(path).close()  # readable as well as a file: the import below would say less
    except UserFileError as err:
        raise WrapError(str(err)) from None
    if path.suffix != ".py":
        raise WrapError(f"{path} is not a Python file (.py)")
    data = path.read_bytes()
    if b"\0" in data:  # compile() says so without a line
        line = data.count(b"\n", 0, data.index(b"\0")) + 1
        raise WrapError(f"importing {path.name} failed at line {line}: a NUL byte (a Python file is text)")
    name = f"tiltload_wrap_{hashlib.sha256(str(path.resolve()).encode()).hexdigest()[:8]}"
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    try:
        spec.loader.exec_module(module)
    except USER_ENDS as err:  # the user's code: one line, what and where
        where = f" at line {err.lineno}" if isinstance(err, SyntaxError) and err.lineno else ""
        where = where or (f" at {line}" if (line := user_line(err, path)) else "")
        raise WrapError(f"importing {path.name} failed{where}: {_what(err)}") from None
    finally:
        sys.modules.pop(name, None)
    return module


def _what(err: BaseException) -> str:
    """What the user's code raised, in words; sys.exit() named as such."""
    if isinstance(err, SystemExit):
        return f"it calls sys.exit({'' if err.code is None else repr(err.code)}), which a controller's code may not"
    text = str(err).splitlines()[0] if str(err) else ""
    return f"{text} ({type(err).__name__})" if text else type(err).__name__


def find_class(module, path: Path, class_name: str | None):
    candidates = {n: c for n, c in inspect.getmembers(module, inspect.isclass)
                  if c.__module__ == module.__name__ and callable(getattr(c, "step", None))}
    if class_name:
        if class_name not in candidates:
            raise WrapError(f"{path.name} has no class {class_name} with a step method (found: {', '.join(candidates) or 'none'})")
        return class_name, candidates[class_name]
    if len(candidates) != 1:
        raise WrapError(f"{path.name} defines {len(candidates)} classes with a step method "
                        f"({', '.join(candidates) or 'none'}); name one with --class")
    return next(iter(candidates.items()))


def describe_class(cls: type, path: Path) -> dict:
    """Check the controller class (imported from the file path) against the contract: the ports, parameters and period
    it declares, from its declarations alone (none of its methods run)."""
    from ....plant_fmu import parameters as P
    from ....plant_fmu.trim import hover_trim
    from ....sensor_fmu.measurement import pi

    name = cls.__name__
    trim = hover_trim(P.default_vector())
    contract = contract_inputs(trim.x, pi(trim.x, P.default_vector()))
    wanted = getattr(cls, "inputs", None)
    if not isinstance(wanted, (list, tuple)) or not wanted or not all(isinstance(n, str) for n in wanted):
        raise WrapError(f"{name}.inputs must be a non-empty list of port names (docs/ports.md)")
    for port in wanted:
        if port not in contract:
            same_words = [c for c in contract if sorted(c.split("_")) == sorted(port.split("_"))]  # ref_x -> x_ref
            close = same_words or difflib.get_close_matches(port, contract, n=1)
            hint = f" (did you mean '{close[0]}'?)" if close else ""
            raise WrapError(f"{name}.inputs: '{port}' is not a port of the controller contract{hint}")
    if len(set(wanted)) != len(wanted):
        raise WrapError(f"{name}.inputs names a port twice")
    params = getattr(cls, "parameters", {}) or {}
    if not isinstance(params, dict):
        raise WrapError(f"{name}.parameters must be a dict of name: number")
    for key, value in params.items():
        if not (isinstance(key, str) and re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", key)) or key in contract or key in REQUIRED_OUTPUTS:
            raise WrapError(f"{name}.parameters: {key!r} must be an identifier that is not a port name")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise WrapError(f"{name}.parameters: {key} = {value!r} must be a finite number")
    period = getattr(cls, "period", TICK)
    ticks = round(period / TICK) if isinstance(period, (int, float)) and math.isfinite(period) else 0
    if ticks < 1 or abs(ticks * TICK - period) > 1e-9:
        raise WrapError(f"{name}.period = {period!r} s must be a whole multiple of the 12 ms tick")
    return {"class": name, "module": path.stem, "period": ticks * TICK,
            "inputs": {p: [contract[p][0], contract[p][1], contract[p][2], contract[p][3]] for p in wanted},
            "outputs": {o: [OUTPUT_UNITS[o], float(trim.u[i])] for i, o in enumerate(REQUIRED_OUTPUTS)},
            "parameters": {k: float(v) for k, v in params.items()},
            "author": str(getattr(cls, "author", "tiltload wrap")),
            "description": (inspect.getdoc(cls) or f"{name}, wrapped by tiltload wrap").splitlines()[0]}


def add_units(fmu: Path, units: dict[str, str]) -> None:
    """pythonfmu 0.7 writes no units: add unit= to the named Reals and the UnitDefinitions block."""
    import xml.etree.ElementTree as ET
    import zipfile

    from ....native_fmu.units import base_exponents

    with zipfile.ZipFile(fmu) as z:
        entries = [(info, z.read(info)) for info in z.infolist()]
    for i, (info, data) in enumerate(entries):
        if info.filename != "modelDescription.xml":
            continue
        root = ET.fromstring(data)
        for sv in root.iter("ScalarVariable"):
            real = sv.find("Real")
            if real is not None and units.get(sv.get("name")):
                real.set("unit", units[sv.get("name")])
        used = sorted({u for u in units.values() if u})
        if used:
            block = ET.Element("UnitDefinitions")
            for unit in used:
                ET.SubElement(ET.SubElement(block, "Unit", {"name": unit}), "BaseUnit",
                              {k: str(e) for k, e in base_exponents(unit).items()})
            after = [k for k, child in enumerate(root) if child.tag in ("ModelExchange", "CoSimulation")]
            root.insert(after[-1] + 1 if after else 0, block)
        entries[i] = (info, b'<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="utf-8"))
    with zipfile.ZipFile(fmu, "w", zipfile.ZIP_DEFLATED) as z:
        for info, data in entries:
            z.writestr(info, data)


def package(path: Path, spec: dict, target: Path) -> Path:
    """Build the pythonfmu FMU of a described class at target. pythonfmu imports the user's file to build: this runs in
    wrap's child process (sandbox.wrap_python), never in tiltload's own."""
    model = spec["model"] = spec["class"]
    digest = hashlib.sha256(path.read_bytes() + json.dumps(spec, sort_keys=True).encode()).hexdigest()
    with tempfile.TemporaryDirectory(prefix="tiltload_wrap_") as tmp:
        stage = Path(tmp)
        slave = stage / "slave.py"  # the template, its class named after the user's (the model identifier)
        slave.write_text(SLAVE.read_text().replace("class TiltloadWrapped(", f"class {model}("))
        (stage / "wrap.json").write_text(json.dumps(spec, indent=1))
        (stage / "__init__.py").write_text("")
        packaging.build_python_fmu(slave=slave, unique=f"tiltload_wrap_{model.lower()}_{digest[:8]}", package_files=[path],
                                   generated=[stage / "wrap.json", stage / "__init__.py"],
                                   build_info={"source_hash": digest, "wrapped": path.name, "class": model,
                                               "source": path.read_text(errors="replace")},
                                   target=target)
    add_units(target, {**{n: v[1] for n, v in spec["inputs"].items()}, **{n: v[0] for n, v in spec["outputs"].items()}})
    return target

"""Declarative description of a co-simulation: FMU instances, their periods and parameters, connections.

A system is plain data (JSON on disk, or an SSP package: ssp.py): the engine knows nothing of the
FMUs it runs. The tiltload loop is one such system, built by the application (app/loop/thesis.py).
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

from .errors import DescriptionError


@dataclass
class Instance:
    name: str
    fmu: Path
    period: float | None = None  # s; None: the tick
    parameters: dict[str, object] = field(default_factory=dict)
    # when the outputs after doStep(t, h) belong (edges.py): "continuous", at t + h (FMI's rule, the default); "sample", at
    # t (a sampled-data element that computes them at its step's start and holds them; it gets a closing sample at T)
    timing: str = "continuous"
    remote: str | None = None  # "HOST:PORT": the FMU runs on the `tiltload serve` there (fmu is the local copy it must match)
    token_file: Path | None = None  # the shared secret for remote: the run's, never written into a description
    fmi: int | None = None  # the FMI version the description names (2 or 3; checked against the FMU), None: any
    input_file: Path | None = None  # a table of its inputs over time, CSV or Parquet (inputs.py), as FMPy's --input-file


@dataclass
class Connection:
    source: str  # "instance.variable"
    target: str  # "instance.variable"
    delay: int = 0  # ticks of transport delay (0: same tick)


@dataclass
class System:
    tick: float
    instances: list[Instance]  # in the in-tick stepping order
    connections: list[Connection] = field(default_factory=list)  # explicit; the rest by unique name
    auto_connect: bool = True
    faults: list = field(default_factory=list)  # faults.schedule.Fault: injected between outputs and inputs
    # an FMU asking to end the simulation (edges.py): "end" ends the run there, as FMPy does; "error" fails it (a loop
    # whose plant stops when its state diverges: the thesis's)
    fmu_end: str = "end"
    start_time: float = 0.0  # s: the FMUs set up at it, tick k at start_time + k * tick; a stop time is absolute (FMPy's)

    def instance(self, name: str) -> Instance:
        for inst in self.instances:
            if inst.name == name:
                return inst
        raise DescriptionError(f"unknown FMU instance '{name}' (have: {', '.join(i.name for i in self.instances)})")


def _split(ref: str, what: str) -> tuple[str, str]:
    if not isinstance(ref, str) or "." not in ref:
        raise DescriptionError(f"connection {what} '{ref}' must be 'instance.variable'")
    inst, var = ref.split(".", 1)
    return inst, var


def parse_address(text: str, port_zero: bool = False) -> tuple[str, int]:
    """HOST:PORT (an IPv6 host in brackets: [::1]:7390) as (host, port); ValueError says what is wrong.
    port_zero: port 0 (a listener's "any free port") is allowed."""
    host, sep, port = str(text).rpartition(":")
    if not sep or not host or not port.isdigit() or not (0 if port_zero else 1) <= int(port) < 65536:
        raise ValueError(f"'{text}' is not HOST:PORT (e.g. 127.0.0.1:7390)")
    if host.startswith("[") and host.endswith("]"):
        host = host[1:-1]
        if not re.fullmatch(r"[0-9A-Fa-f:.]+(%[\w.-]+)?", host):
            raise ValueError(f"'{text}': {host!r} is not an IPv6 address")
    elif ":" in host:
        raise ValueError(f"'{text}': an IPv6 address goes in brackets ([::1]:7390)")
    elif not re.fullmatch(r"[A-Za-z0-9]([A-Za-z0-9_.-]{0,252})", host):  # a host name or IPv4 address (RFC 1123's letters)
        raise ValueError(f"'{text}': {host!r} is not a host name or address")
    return host, int(port)


def faults_from_zero(start_time: float, faults) -> None:
    """Faults are scheduled from t = 0: a system that starts later takes none (a fresh run's or a restart's)."""
    if start_time and faults:
        raise DescriptionError(f"the system starts at {start_time:g} s and has faults, which tiltload schedules from "
                               "t = 0 only")


def validate(system: System) -> System:
    if not (isinstance(system.tick, (int, float)) and math.isfinite(system.tick) and system.tick > 0):
        raise DescriptionError(f"tick must be a positive time, got {system.tick!r}")
    t0 = system.start_time
    if not (isinstance(t0, (int, float)) and math.isfinite(t0) and t0 >= 0):
        raise DescriptionError(f"start time must be a time of 0 s or later, got {t0!r}")
    faults_from_zero(t0, system.faults)
    names = [i.name for i in system.instances]
    if not names:
        raise DescriptionError("the system has no FMU instance")
    dup = {n for n in names if names.count(n) > 1}
    if dup:
        raise DescriptionError(f"duplicate instance names: {', '.join(sorted(dup))}")
    for inst in system.instances:
        if inst.period is not None:
            n = round(inst.period / system.tick)
            if not (math.isfinite(inst.period) and n >= 1 and abs(n * system.tick - inst.period) <= 1e-9 * inst.period):
                raise DescriptionError(f"{inst.name}: period {inst.period!r} s is not a whole multiple of the tick {system.tick} s")
        if inst.timing not in ("sample", "continuous"):
            raise DescriptionError(f"{inst.name}: timing must be 'sample' or 'continuous', got {inst.timing!r}")
        if inst.remote is not None:
            try:
                parse_address(inst.remote)
            except ValueError as err:
                raise DescriptionError(f"{inst.name}: remote {err}") from None
        if inst.fmi not in (None, 2, 3):
            raise DescriptionError(f"{inst.name}: fmi must be 2 or 3 (the FMI version), got {inst.fmi!r}")
    for c in system.connections:
        for ref, what in ((c.source, "source"), (c.target, "target")):
            inst, _ = _split(ref, what)
            system.instance(inst)
        if not (isinstance(c.delay, int) and c.delay >= 0):
            raise DescriptionError(f"connection {c.source} -> {c.target}: delay must be a non-negative integer of ticks")
    return system


_NAME = r"^[A-Za-z_][A-Za-z0-9_]*$"
_REF = r"^[A-Za-z_][A-Za-z0-9_]*\.[^\s.][^\s]*$"
SCHEMA = {
    "type": "object", "additionalProperties": False, "required": ["tick", "instances"],
    "properties": {
        "tick": {"type": "number", "exclusiveMinimum": 0, "maximum": 3600},
        "start_time": {"type": "number", "minimum": 0, "maximum": 1e9},
        "auto_connect": {"type": "boolean"},
        "fmu_end": {"enum": ["end", "error"]},
        "instances": {"type": "array", "minItems": 1, "items": {
            "type": "object", "additionalProperties": False, "required": ["name", "fmu"],
            "properties": {
                "name": {"type": "string", "pattern": _NAME},
                "fmu": {"type": "string", "minLength": 1},
                "period": {"type": ["number", "null"], "exclusiveMinimum": 0},
                "parameters": {"type": "object", "propertyNames": {"pattern": "^[^\\s]+$"},
                               "additionalProperties": {"type": ["number", "string", "boolean"]}},
                "timing": {"enum": ["sample", "continuous"]},
                "remote": {"type": "string", "minLength": 3, "maxLength": 300},
                "fmi": {"enum": [2, 3]},
                "input_file": {"type": "string", "minLength": 1, "maxLength": 4096}}}},
        "connections": {"type": "array", "items": {
            "type": "object", "additionalProperties": False, "required": ["source", "target"],
            "properties": {"source": {"type": "string", "pattern": _REF}, "target": {"type": "string", "pattern": _REF},
                           "delay": {"type": "integer", "minimum": 0, "maximum": 1000}}}},
        "faults": {"type": "array"},
    },
}


def _check_schema(data, path: Path) -> None:
    """The description's shape: unknown keys, wrong types and out-of-range values named by their path."""
    from .user_files import schema_problem

    problem = schema_problem(data, SCHEMA)
    if problem:
        raise DescriptionError(f"{path}: {problem}")


def load(path: Path) -> System:
    """Read a system description (JSON), checked against SCHEMA; FMU paths are relative to the file."""
    from .user_files import UserFileError, read_json

    path = Path(path)
    if not path.exists():
        raise DescriptionError(f"system description {path} does not exist")
    try:
        data = read_json(path)
    except UserFileError as err:
        raise DescriptionError(f"system description {err}") from None
    _check_schema(data, path)
    try:
        instances = [Instance(i["name"], (path.parent / i["fmu"]).resolve(), i.get("period"), dict(i.get("parameters", {})),
                              i.get("timing", "continuous"), remote=i.get("remote"), fmi=i.get("fmi"),
                              input_file=(path.parent / i["input_file"]).resolve() if i.get("input_file") else None)
                     for i in data["instances"]]
        conns = [Connection(c["source"], c["target"], int(c.get("delay", 0))) for c in data.get("connections", [])]
        system = System(float(data["tick"]), instances, conns, bool(data.get("auto_connect", True)),
                        fmu_end=data.get("fmu_end", "end"), start_time=float(data.get("start_time", 0.0)))
        if "faults" in data:
            from .faults.parse import parse

            system.faults = parse(data["faults"], f"{path}: faults")
    except DescriptionError:
        raise
    except (KeyError, TypeError, ValueError) as err:
        raise DescriptionError(f"{path}: malformed system description ({err})") from None
    return validate(system)


def save(system: System, path: Path) -> Path:
    data = {"tick": system.tick, "auto_connect": system.auto_connect, **({"fmu_end": "error"} if system.fmu_end == "error" else {}),
            **({"start_time": system.start_time} if system.start_time else {}),
            "instances": [{"name": i.name, "fmu": str(i.fmu), "period": i.period, "parameters": i.parameters, "timing": i.timing,
                           **({"remote": i.remote} if i.remote else {}), **({"fmi": i.fmi} if i.fmi is not None else {}),
                           **({"input_file": str(i.input_file)} if i.input_file is not None else {})}
                          for i in system.instances],
            "connections": [{"source": c.source, "target": c.target, "delay": c.delay} for c in system.connections]}
    Path(path).write_text(json.dumps(data, indent=1))
    return Path(path)

"""Argument types of the `tiltload` command and the options that describe a run of the loop."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from ..command_line.argument_types import DAY, integer, positive_number, positive_time, real_in, run_time, time_span, tolerance
from ..command_line.path_types import existing_folder, folder, kind, output_file
from .loop import defaults

# the checks are the engine's (one implementation, shared with tiltload serve); the commands find them here
__all__ = ["DAY", "existing_folder", "folder", "integer", "output_file", "positive_number", "positive_time", "run_time", "time_span",
           "tolerance"]

DEFAULT_FMU_DIR = defaults.FMU_DIR  # the commands' --fmus
MAX_REALTIME_FACTOR = 1000.0  # --realtime: the pacer waits tick / factor; beyond these bounds a wait overflows or means nothing


_realtime_range = real_in(lambda value: 1 / MAX_REALTIME_FACTOR <= value <= MAX_REALTIME_FACTOR,
                          f"from {1 / MAX_REALTIME_FACTOR:g} to {MAX_REALTIME_FACTOR:g}")


def realtime_factor(text: str) -> float:
    positive_number(text)  # not a number, or not above 0: that line first
    return _realtime_range(text)


def assignment(text: str) -> tuple[str, object]:
    from .loop.thesis import parse_value

    key, sep, value = text.partition("=")
    if not sep or "." not in key or not value:
        raise argparse.ArgumentTypeError(f"must be INSTANCE.NAME=VALUE (e.g. plant.m_L=0.2), got {text!r}")
    parsed = parse_value(value.strip())
    if isinstance(parsed, float) and not math.isfinite(parsed) or type(parsed) is int and abs(parsed) >= 2**63:
        raise argparse.ArgumentTypeError(f"{key.strip()}: {value.strip()[:40]} is not a finite number an FMU parameter can hold")
    return key.strip(), parsed


tilt_limit = real_in(lambda value: 0 < value <= 180, "an angle in degrees, above 0 and at most 180")
seed = integer(0, 2**31 - 1)
whole_number = integer(1)


def controller(text: str) -> str:
    """dlqr, mixed or an existing controller FMU file (the --controller of a side of b2b)."""
    if text in ("dlqr", "mixed") or (text.endswith(".fmu") and Path(text).is_file()):
        return text
    if text.endswith(".fmu"):
        raise argparse.ArgumentTypeError(f"controller {text} does not exist" if not Path(text).exists() else
                                         f"controller {text} is {kind(Path(text))}, not an FMU file")
    raise argparse.ArgumentTypeError(f"{text!r} is neither dlqr, mixed nor an existing FMU file")


def expected_fmu(text: str) -> tuple[str, str]:
    """INSTANCE=SHA256: the FMU an instance must run (a replay pinned to the build it replays)."""
    import re

    instance, sep, digest = text.partition("=")
    digest = digest.strip().lower()
    if not sep or not instance.strip() or not re.fullmatch(r"[0-9a-f]{64}", digest):
        raise argparse.ArgumentTypeError(f"must be INSTANCE=SHA256 (64 hex digits, e.g. controller=3f2a...), got {text!r}")
    return instance.strip(), digest


def file_stem(text: str) -> str:
    if not text or text in (".", "..") or "/" in text or "\\" in text or "\0" in text or "\n" in text:
        raise argparse.ArgumentTypeError(f"must be a plain file name (no folders), got {text!r}")
    return text


def remote(text: str) -> tuple[str, str]:
    """INSTANCE=HOST:PORT: that instance's FMU runs on the `tiltload serve` at HOST:PORT."""
    from ..engine.system import parse_address

    name, sep, address = text.partition("=")
    if not sep or not name.strip():
        raise argparse.ArgumentTypeError(f"must be INSTANCE=HOST:PORT (e.g. controller=192.168.1.20:7390), got {text!r}")
    try:
        parse_address(address.strip())
    except ValueError as err:
        raise argparse.ArgumentTypeError(str(err)) from None
    return name.strip(), address.strip()


def add_loop_options(p: argparse.ArgumentParser) -> None:
    """What describes a run of the loop: shared by run and ssp export (resolved by options.resolve_loop). The loop's
    own options default to None (False for flags), so that resolve_loop knows which were given: with --system they
    are refused, not ignored."""
    p.add_argument("--vehicle", choices=("load", "uav"), default=None,
                   help="load: the UAV with its suspended load (ch. 5, default); uav: the UAV alone (Appendix A)")
    p.add_argument("--scenario", choices=defaults.SCENARIOS, default=None, help=f"estimation scenario (default {defaults.SCENARIO})")
    p.add_argument("--trajectory", default=None, metavar="N|SHAPE|FILE",
                   help="load: 1 circle (default), 2 Table 5.3; uav: 3 Appendix A's circle (default); 0 hover; a shape "
                        "(lemniscate, lissajous, step-x/y/z, ramp-x/y/z, with :KEY=VALUE,... e.g. step-z:size=0.5); or a "
                        "waypoint file (CSV t,x,y,z[,psi], JSON/YAML): docs/test_bench.md")
    p.add_argument("--wind", type=Path, default=None, metavar="FILE",
                   help="wind on the load: steady, Dryden turbulence, a profile (YAML/JSON, or a CSV profile t,x,y,z); "
                        "seeded by --seed; docs/test_bench.md")
    p.add_argument("--allow-infeasible", action="store_true",
                   help="run a reference the actuators cannot follow (Table 5.2), with a warning instead of refusing it")
    p.add_argument("--max-tilt", type=tilt_limit, default=defaults.MAX_TILT, metavar="DEG",
                   help="largest trim tilt angle the feasibility check accepts (default 30 degrees)")
    p.add_argument("--controller", default=None,
                   help="dlqr, mixed (the load's default; the UAV alone has dlqr), PATH.fmu of your own controller, or "
                        "PATH.py of a controller class (run: wrapped on the fly, natively where it traces; docs/ports.md)")
    p.add_argument("--seed", type=seed, default=None, help="noise seed, 0 .. 2147483647 (default 1)")
    p.add_argument("--stop-time", type=run_time, default=None, help="s (default: the trajectory's duration; at most 1e6)")
    p.add_argument("--delay", action="store_true", help="one-tick actuation delay (controller -> plant)")
    p.add_argument("--no-gusts", action="store_true", help="no wind gusts")
    p.add_argument("--faults", type=Path, default=None, metavar="FILE",
                   help="a fault schedule (JSON/YAML, or a libcosim scenario): docs/faults.md")
    p.add_argument("--set", type=assignment, action="append", default=[], metavar="INSTANCE.NAME=VALUE",
                   help="set an FMU parameter, e.g. --set plant.m_L=0.2 (repeatable)")
    p.add_argument("--system", type=Path, default=None,
                   help="an SSP package (.ssp/.ssd) or a JSON system description instead of the loop (the loop's options "
                        "--vehicle, --scenario, --trajectory, --controller, --seed, --delay, --no-gusts, --set, --fmus do "
                        "not apply to it; --faults and --stop-time do)")
    p.add_argument("--allow-external-fmus", action="store_true",
                   help="--system: let a component's FMU lie outside the package or the system file's folder")
    p.add_argument("--fmus", type=folder, default=None, help="FMU folder (default: fmus)")
    p.add_argument("--fmi", type=int, choices=(2, 3), default=None,
                   help="the loop's FMUs as FMI 2.0 (default; in FMUS/) or FMI 3.0 co-simulation FMUs (in FMUS/fmi3/)")
    p.add_argument("--clocks", action="store_true",
                   help="with --fmi 3: the sensors and the controller with FMI 3.0 clocks, which replace their periods "
                        "(default: the plain FMI 3.0 FMUs, which every FMI 3.0 importer runs; docs/fmi3.md)")
    p.add_argument("--allow-unknown-inputs", action="store_true",
                   help="accept a controller FMU whose inputs include names the port contract does not have")
    p.add_argument("--remote", type=remote, action="append", default=[], metavar="INSTANCE=HOST:PORT",
                   help="run that instance's FMU on the tiltload serve at HOST:PORT (the same FMU, picked there by model "
                        "identifier and GUID; docs/remote.md); repeatable")


def checked(parse, flag: str, value: object, command: str = "run"):
    """A value of the Python API checked by the option's own type, as its text: the same value, the same line (a
    TiltloadError carrying `tiltload COMMAND`'s usage line) as the command's parser."""
    from .user_error import usage_error

    text = repr(value) if isinstance(value, float) else str(value)
    try:
        return parse(text)
    except argparse.ArgumentTypeError as err:
        raise usage_error(command, f"argument {flag}: {err}") from None


def named(parse, name: str, value: object):
    """A value of the Python API checked by an option's type, refused as "NAME: the type's line" (a TiltloadError)."""
    from .user_error import TiltloadError

    try:
        return parse(repr(value) if isinstance(value, float) else str(value))
    except argparse.ArgumentTypeError as err:
        raise TiltloadError(f"{name}: {err}") from None


def chosen(flag: str, value: object, choices: tuple, command: str = "run") -> None:
    """A value of the Python API among an option's choices, refused with the parser's line."""
    from .user_error import usage_error

    if value is not None and value not in choices:
        raise usage_error(command, f"argument {flag}: invalid choice: {value!r} (choose from {', '.join(map(repr, choices))})")


def snapshot_time(at: object) -> float:
    """--snapshot-at's T (text from the command line, a number from the API), its line as the command says it."""
    from .user_error import UserError

    try:
        return positive_time(repr(at) if isinstance(at, float) else str(at))
    except argparse.ArgumentTypeError as err:
        raise UserError(f"--snapshot-at {at}: {err}") from None

"""The value types of what describes a run and how it runs, declared once for both faces: `tiltload`'s parsers take
them as their options' types (the field `stop_time` is the option `--stop-time`: the command line maps its flags onto
the fields), and the API's request objects (Case, RunOptions, CampaignOptions, FalsifyOptions) check their fields'
values by the same types, refusing a value with the line that command's parser prints for it (docs/api.md)."""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

from ...command_line.argument_types import DAY, integer, real_in, run_time, time_span
from ...command_line.path_types import folder, output_file
from ..loop.defaults import SCENARIOS

MAX_REALTIME_FACTOR = 1000.0  # --realtime: the pacer waits tick / factor; beyond these bounds a wait overflows or means nothing


def flag_of(name: str) -> str:
    """A field's option: its name with dashes."""
    return "--" + name.replace("_", "-")


@dataclass(frozen=True)
class Fields:
    """The value types (and choices) of one request's fields, and the command whose parser says a refusal."""

    command: str
    types: Mapping[str, Callable[[str], object]]
    choices: Mapping[str, tuple] = field(default_factory=dict)

    def option(self, name: str) -> dict:
        """The keywords of argparse's add_argument for the field's option: its type or its choices."""
        return {"type": self.types[name]} if name in self.types else {"choices": self.choices[name]}

    def check(self, name: str, value: object) -> object:
        """The value as the option's type reads its text (a TiltloadError with the parser's line if it refuses it)."""
        from ..user_error import usage_error

        text = repr(value) if isinstance(value, float) else str(value)
        try:
            return self.types[name](text)
        except argparse.ArgumentTypeError as err:
            raise usage_error(self.command, f"argument {flag_of(name)}: {err}") from None

    def choose(self, name: str, value: object) -> None:
        """None, or one of the option's choices (else the parser's line)."""
        from ..user_error import usage_error

        choices = self.choices[name]
        if value is not None and value not in choices:
            raise usage_error(self.command, f"argument {flag_of(name)}: invalid choice: {value!r} "
                                            f"(choose from {', '.join(map(repr, choices))})")


def named(parse: Callable[[str], object], name: str, value: object) -> object:
    """A value of a function's argument (not a request's field) checked by an option's type, refused as "NAME: the
    type's line" (a TiltloadError): b2b's and compare's tolerances, folders, stop times."""
    from ..user_error import TiltloadError

    try:
        return parse(repr(value) if isinstance(value, float) else str(value))
    except argparse.ArgumentTypeError as err:
        raise TiltloadError(f"{name}: {err}") from None


def snapshot_time(at: object) -> float:
    """--snapshot-at's T (text from the command line, a number from the API), its line as the command says it."""
    from ...command_line.argument_types import positive_time
    from ..user_error import UserError

    try:
        return positive_time(repr(at) if isinstance(at, float) else str(at))
    except argparse.ArgumentTypeError as err:
        raise UserError(f"--snapshot-at {at}: {err}") from None


_realtime_range = real_in(lambda value: 1 / MAX_REALTIME_FACTOR <= value <= MAX_REALTIME_FACTOR,
                          f"from {1 / MAX_REALTIME_FACTOR:g} to {MAX_REALTIME_FACTOR:g}")


def realtime_factor(text: str) -> float:
    from ...command_line.argument_types import positive_number

    positive_number(text)  # not a number, or not above 0: that line first
    return _realtime_range(text)


def assignment(text: str) -> tuple[str, object]:
    """INSTANCE.NAME=VALUE: an FMU parameter's value (checked against the FMU's type when the system is built)."""
    from ..loop.thesis import parse_value

    key, sep, value = text.partition("=")
    if not sep or "." not in key or not value:
        raise argparse.ArgumentTypeError(f"must be INSTANCE.NAME=VALUE (e.g. plant.m_L=0.2), got {text!r}")
    parsed = parse_value(value.strip())
    if isinstance(parsed, float) and not math.isfinite(parsed) or type(parsed) is int and abs(parsed) >= 2**63:
        raise argparse.ArgumentTypeError(f"{key.strip()}: {value.strip()[:40]} is not a finite number an FMU parameter can hold")
    return key.strip(), parsed


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
    from ...engine.system import parse_address

    name, sep, address = text.partition("=")
    if not sep or not name.strip():
        raise argparse.ArgumentTypeError(f"must be INSTANCE=HOST:PORT (e.g. controller=192.168.1.20:7390), got {text!r}")
    try:
        parse_address(address.strip())
    except ValueError as err:
        raise argparse.ArgumentTypeError(str(err)) from None
    return name.strip(), address.strip()


def input_file(text: str) -> tuple[str, str]:
    """INSTANCE=FILE: a table of that instance's inputs over time (CSV or Parquet, engine/inputs.py)."""
    name, sep, path = text.partition("=")
    if not sep or not name.strip() or not path.strip():
        raise argparse.ArgumentTypeError(f"must be INSTANCE=FILE (e.g. plant=inputs.csv), got {text!r}")
    return name.strip(), path.strip()


tilt_limit = real_in(lambda value: 0 < value <= 180, "an angle in degrees, above 0 and at most 180")
step_size = real_in(lambda value: 0 < value <= 3600, "a step in seconds, above 0 and at most 3600")
start_at = real_in(lambda value: 0 <= value <= 1e9, "a time in seconds, 0 or later and at most 1e9")
seed = integer(0, 2**31 - 1)
whole_number = integer(1)

# Case: what one run is (tiltload run's loop options)
CASE = Fields("run", {"seed": seed, "stop_time": run_time, "fmus": folder, "max_tilt": tilt_limit, "set": assignment,
                      "remote": remote, "step": step_size, "input_file": input_file,
                      "start_time": start_at},
              {"vehicle": ("load", "uav"), "scenario": SCENARIOS, "schedule": ("ordered", "jacobi"), "fmi": (2, 3)})
# RunOptions: how it runs and what is kept of it (tiltload run's other options)
RUN = Fields("run", {"out": folder, "name": file_stem, "log_every": whole_number, "report": output_file,
                     "expect_fmu": expected_fmu, "realtime": realtime_factor, "max_overruns": integer(0),
                     "step_timeout": time_span(DAY)})

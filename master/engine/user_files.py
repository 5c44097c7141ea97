"""Every file a user hands in (waypoints, wind, faults, campaign specs, system descriptions) is read here, bounded
before it is read: a regular file under a size limit, UTF-8 text, documents nested at most MAX_DEPTH deep, integers of
at most MAX_INT_DIGITS digits, every number finite, YAML without aliases, CSV lines of at most MAX_LINE characters.

Why YAML aliases are refused outright rather than counted: an alias bomb is nine levels of ten aliases (90 of them)
expanding to 10^9 nodes, so a bound on their number bounds nothing; a bound on the expanded size would, but none of
these files needs to repeat a block (a grid's values, a fault's targets are short lists). Anchors alone are harmless.

Every failure is a UserFileError whose message is one line naming the file and the problem (docs/master.md, Input files).
"""

from __future__ import annotations

import csv
import json
import math
import os
import stat
import tomllib
from pathlib import Path

MAX_BYTES = 16 * 2**20  # a 10,000-waypoint CSV with every column is about 3 MB
MAX_DEPTH = 32  # nesting of lists and mappings (the deepest file we read, a campaign spec, nests 5)
MAX_INT_DIGITS = 18  # an integer beyond 10^18 is no count, seed or time any of these files holds (int64 holds 9.2e18)
MAX_LINE = 4096  # characters in a CSV line (a waypoint row with all 13 columns at 17 digits is ~300)


class UserFileError(ValueError):
    """A file the user gave that cannot be used as it is; the message is one line naming the file and the problem."""


class _Refused:
    """A JSON number refused as it was parsed (never converted): check_values reports it with its place."""

    def __init__(self, why: str) -> None:
        self.why = why


def _kind(mode: int) -> str:
    for test, name in ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO"), (stat.S_ISCHR, "a character device"),
                       (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return name
    return "not a regular file"


def _why(err: OSError) -> str:
    if isinstance(err, PermissionError):
        return "permission denied"
    if isinstance(err, FileNotFoundError):
        return "no such file"
    if isinstance(err, NotADirectoryError):
        return "a part of its path is not a folder"
    return f"cannot read it: {err.strerror or err}"


def regular_file(path: Path, what: str = "") -> Path:
    """The path, if it names a regular file (stat only: nothing is opened); else UserFileError, one line saying what it
    is instead (missing, a folder, a FIFO, a device, behind a permission). what: a word for the file ("log", "snapshot")."""
    path = Path(path)
    named = f"{what} {path}" if what else str(path)
    try:
        info = path.stat()
    except OSError as err:
        raise UserFileError(f"{named}: {_why(err)}") from None
    if not stat.S_ISREG(info.st_mode):
        kind = _kind(info.st_mode)
        raise UserFileError(f"{named}: {kind}, not a regular file" if kind != "not a regular file" else f"{named}: {kind}")
    return path


def open_binary(path: Path, what: str = ""):
    """The user's file opened for reading (binary), never blocking: checked by regular_file, opened with O_NONBLOCK
    (a FIFO swapped in after the stat opens at once instead of waiting for a writer) and checked again on the open
    descriptor. Every way the open fails is one UserFileError line (permission denied, not "not a log")."""
    path = regular_file(path, what)
    named = f"{what} {path}" if what else str(path)
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0))
    except OSError as err:
        raise UserFileError(f"{named}: {_why(err)}") from None
    try:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            raise UserFileError(f"{named}: {_kind(mode)}, not a regular file")
        return os.fdopen(fd, "rb")
    except BaseException:
        os.close(fd)
        raise


def read_text(path: Path, max_bytes: int = MAX_BYTES) -> str:
    """The file's text: a regular file (open_binary: a FIFO or a device is never read) of at most max_bytes, UTF-8."""
    path = Path(path)
    with open_binary(path) as f:
        size = os.fstat(f.fileno()).st_size
        if size > max_bytes:
            raise UserFileError(f"{path}: {size} bytes, more than the {max_bytes} a file given to tiltload may have")
        try:
            data = f.read(max_bytes + 1)  # the file may have grown since fstat
        except OSError as err:
            raise UserFileError(f"{path}: {_why(err)}") from None
    if len(data) > max_bytes:
        raise UserFileError(f"{path}: more than the {max_bytes} bytes a file given to tiltload may have")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as err:
        raise UserFileError(f"{path}: not a UTF-8 text file (byte {err.start})") from None
    if "\x00" in text:
        raise UserFileError(f"{path}: not a text file (it holds a NUL character)")
    return text.removeprefix("\ufeff")


def read_json(path: Path, max_bytes: int = MAX_BYTES):
    """A JSON document, its numbers checked as they are parsed (finite, integers of at most MAX_INT_DIGITS digits)."""
    path = Path(path)
    text = read_text(path, max_bytes)

    def integer(digits: str):
        n = len(digits.lstrip("-"))
        return _Refused(f"an integer of {n} digits (at most {MAX_INT_DIGITS})") if n > MAX_INT_DIGITS else int(digits)

    def real(digits: str):
        value = float(digits)
        return value if math.isfinite(value) else _Refused(f"{digits[:24]}{'...' * (len(digits) > 24)} is beyond a double's range")

    def constant(name: str):
        return _Refused(f"{name} is not a finite number")

    try:
        data = json.loads(text, parse_int=integer, parse_float=real, parse_constant=constant)
    except json.JSONDecodeError as err:
        raise UserFileError(f"{path}: not valid JSON: {err}") from None
    except RecursionError:
        raise UserFileError(f"{path}: nested deeper than {MAX_DEPTH} levels") from None
    check_values(data, str(path))
    return data


def read_yaml(path: Path, max_bytes: int = MAX_BYTES):
    """A YAML document (safe types only), refused if it uses an alias; numbers finite, integers bounded, keys text."""
    import yaml

    path = Path(path)
    text = read_text(path, max_bytes)

    class NoAliases(yaml.SafeLoader):
        def compose_node(self, parent, index):
            if self.check_event(yaml.AliasEvent):
                mark = self.peek_event().start_mark
                raise UserFileError(f"{path}: line {mark.line + 1}: a YAML alias (*{self.peek_event().anchor}): aliases are "
                                    "not accepted (write the value out)")
            return super().compose_node(parent, index)

    loader = NoAliases(text)
    try:
        data = loader.get_single_data()
    except UserFileError:
        raise
    except RecursionError:
        raise UserFileError(f"{path}: nested deeper than {MAX_DEPTH} levels") from None
    except (yaml.YAMLError, ValueError, OverflowError) as err:  # ValueError, OverflowError: an integer or date out of range
        mark = getattr(err, "problem_mark", None)
        at = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = getattr(err, "problem", None) or (str(err).splitlines() or [type(err).__name__])[0]
        raise UserFileError(f"{path}: not valid YAML{at}: {problem[:200]}") from None
    finally:
        loader.dispose()
    check_values(data, str(path))
    return data


def read_toml(path: Path, max_bytes: int = MAX_BYTES):
    """A TOML document, its values checked as read_json's."""
    path = Path(path)
    text = read_text(path, max_bytes)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise UserFileError(f"{path}: not valid TOML: {err}") from None
    check_values(data, str(path))
    return data


def read_document(path: Path, max_bytes: int = MAX_BYTES):
    """A JSON (.json), YAML (.yaml, .yml) or TOML (.toml) document, by its suffix."""
    suffix = Path(path).suffix.lower()
    if suffix == ".json":
        return read_json(path, max_bytes)
    if suffix in (".yaml", ".yml"):
        return read_yaml(path, max_bytes)
    if suffix == ".toml":
        return read_toml(path, max_bytes)
    raise UserFileError(f"{path}: a document is .json, .yaml, .yml or .toml")


def read_csv(path: Path, max_bytes: int = MAX_BYTES, max_line: int = MAX_LINE) -> list[tuple[int, list[str]]]:
    """A CSV file's lines as (line number, cells), blank lines and lines starting with # left out; every line of at
    most max_line characters (so no cell reaches the csv module's own limit)."""
    path = Path(path)
    rows = []
    for number, line in enumerate(read_text(path, max_bytes).splitlines(), start=1):
        if len(line) > max_line:
            raise UserFileError(f"{path}: line {number}: {len(line)} characters, more than {max_line}")
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        try:
            rows.append((number, next(csv.reader([line]))))
        except (csv.Error, StopIteration) as err:
            raise UserFileError(f"{path}: line {number}: not a CSV line: {err}") from None
    return rows


def check_values(data, source: str) -> None:
    """Every number finite, every integer of at most MAX_INT_DIGITS digits, every mapping key text, nesting at most
    MAX_DEPTH: the first breach as one line naming where it is (walked without recursion)."""
    stack = [(data, "", 0)]
    while stack:
        value, where, depth = stack.pop()
        at = f"{source}: {_printable(where)}: " if where else f"{source}: "
        if depth >= MAX_DEPTH and isinstance(value, (dict, list)):  # the root's container is level 1
            raise UserFileError(f"{at}nested deeper than {MAX_DEPTH} levels")
        if isinstance(value, bool) or value is None or isinstance(value, str):
            continue
        if isinstance(value, _Refused):
            raise UserFileError(f"{at}{value.why}")
        if isinstance(value, int):
            if abs(value) >= 10**MAX_INT_DIGITS:
                raise UserFileError(f"{at}an integer of more than {MAX_INT_DIGITS} digits")
        elif isinstance(value, float):
            if not math.isfinite(value):
                raise UserFileError(f"{at}{value} is not a finite number")
        elif isinstance(value, dict):
            for key in value:
                if not isinstance(key, str):
                    raise UserFileError(f"{at}the key {str(key)[:40]!r} is not text")
            stack.extend((item, f"{where}.{key}" if where else key, depth + 1) for key, item in reversed(value.items()))
        elif isinstance(value, list):  # reversed: the first breach in the file's order is reported
            stack.extend((value[i], f"{where}.{i}" if where else str(i), depth + 1) for i in reversed(range(len(value))))


def _printable(place: str) -> str:
    """A place built from a file's keys, its control characters escaped (a key "a\\n" must not break the one line)."""
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in place)


def _validator(jsonschema):
    """Draft 2020-12, its "pattern" anchored at the very end: Python's `$` (which jsonschema's re.search uses) also
    matches before a final newline, so "name\\n" passed every "^...$" of a spec's names."""
    import re

    def pattern(validator, regex, instance, schema):
        if validator.is_type(instance, "string") and (
                re.search(regex, instance) is None or (regex.endswith("$") and instance.endswith("\n"))):
            yield jsonschema.ValidationError(f"{instance!r} does not match {regex!r}")

    return jsonschema.validators.extend(jsonschema.Draft202012Validator, {"pattern": pattern})


def schema_problem(data, schema: dict, top: str = "(top level)", limit: int = 200) -> str | None:
    """The first place where data breaks the JSON Schema, as "path: message" (None: it fits). The first by path, so
    the same document always gets the same line; the message cut at limit characters (a long enum or a long value)."""
    import jsonschema

    def place(err) -> list:  # list indexes in order, before names (as a document reads)
        return [(0, p, "") if isinstance(p, int) else (1, 0, str(p)) for p in err.absolute_path]

    errors = sorted(_validator(jsonschema)(schema).iter_errors(data), key=place)
    if not errors:
        return None
    err = errors[0]
    where = ".".join(str(p) for p in err.absolute_path) or top
    return f"{where}: {err.message if len(err.message) <= limit else err.message[:limit] + '…'}"

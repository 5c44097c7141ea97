"""Requirement files: named STL requirements over logged signals (`instance.variable`), docs/requirements.md.

A YAML file `requirements: [...]`, each entry a name, a description, a source (where the requirement comes from: a
thesis section, a user's requirement id) and one of:
- `formula`: STL in rtamt's grammar (stl/grammar.py);
- `bounds`: {signal, min, max, from, to}: the signal within [min, max] (either may be left out) over [from, to] s
  (default: the whole run) -> always[from:to] (signal >= min and signal <= max);
- `response`: {trigger, response, within, hold, from, to}: whenever the trigger holds, within `within` s the response
  holds for at least `hold` s -> always[from:to] (trigger implies eventually[0:within] always[0:hold] response).
The sugar's expansion is what is checked (`tiltload check --explain` shows it). Errors are one line naming the file,
the requirement and the problem; a parse error marks its position.
"""

from __future__ import annotations

import difflib
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import DescriptionError
from .stl import StlError, bounded_horizon, parse, signals, unparse
from .stl.grammar import number_text

MAX_BYTES = 1 << 20  # a requirement file is text a person writes: a larger one is a mistake (or an attack on the parser)
_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_.\-]*\Z")
_SIGNAL = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*(?:\.[A-Za-z_][A-Za-z0-9_]*)+\Z")  # instance.variable, as the grammar's
_KEYS = {"name", "description", "source", "formula", "bounds", "response"}
_BOUNDS = {"signal", "min", "max", "from", "to"}
_RESPONSE = {"trigger", "response", "within", "hold", "from", "to"}


class RequirementError(DescriptionError):
    """A requirement file or formula that cannot be checked; the message is one line for the user."""


@dataclass(frozen=True)
class Requirement:
    name: str
    text: str  # the STL checked (a sugar's expansion)
    description: str = ""
    source: str = ""
    sugar: str = ""  # "bounds" or "response" when the text was expanded from one
    formula: object = field(default=None, compare=False, repr=False)  # the syntax tree

    @property
    def signals(self) -> list[str]:
        return signals(self.formula)

    @property
    def horizon(self) -> float:
        return bounded_horizon(self.formula)

    def explain(self) -> str:
        return unparse(self.formula)


def requirement(name: str, text: str, where: str = "", description: str = "", source: str = "", sugar: str = "") -> Requirement:
    """One requirement from its STL; RequirementError naming it if the formula does not parse."""
    if not isinstance(name, str) or not _NAME.match(name):
        raise RequirementError(f"{where}requirement name {name!r}: letters, digits, _ . - (starting with a letter or _)")
    if not isinstance(text, str):
        raise RequirementError(f"{where}requirement '{name}': the formula is text, got {type(text).__name__}")
    try:
        tree = parse(text)
    except StlError as err:
        raise RequirementError(f"{where}requirement '{name}': {err}") from None
    return Requirement(name, text, description, source, sugar, tree)


def from_option(spec: str) -> Requirement:
    """`NAME: STL` (the --formula option)."""
    name, sep, text = spec.partition(":")
    if not sep or not name.strip():
        raise RequirementError(f"--formula {spec!r}: give it as 'NAME: STL', e.g. 'alt: always plant.z > -5'")
    return requirement(name.strip(), text.strip(), "--formula: ")


def _number(value, what: str, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise RequirementError(f"{where}{what} must be a finite number, got {value!r}")
    return float(value)


def _interval(entry: dict, where: str) -> str:
    start, end = entry.get("from", 0.0), entry.get("to")
    a = _number(start, "from", where)
    if a < 0:
        raise RequirementError(f"{where}from = {a:g} s: a negative time (the run starts at 0)")
    if end is None:
        return "" if a == 0 else f"[{number_text(a)}:inf]"  # every digit: :g would move a bound of 12.3456789 s
    b = _number(end, "to", where)
    if b < a:
        raise RequirementError(f"{where}reversed interval from {a:g} to {b:g} s")
    return f"[{number_text(a)}:{number_text(b)}]"


def _expand_bounds(b, where: str) -> str:
    if not isinstance(b, dict) or set(b) - _BOUNDS or "signal" not in b:
        raise RequirementError(f"{where}bounds is a mapping of signal, min, max, from, to (got {b!r:.80})")
    sig = b["signal"]
    if not isinstance(sig, str) or not _SIGNAL.fullmatch(sig):
        # checked before it is spliced into the expansion: a formula or a parenthesis here would change its meaning
        raise RequirementError(f"{where}bounds.signal must be a signal name (instance.variable), got {sig!r:.80}")
    parts = []
    if b.get("min") is not None:
        parts.append(f"{sig} >= {_number(b['min'], 'bounds.min', where)!r}")
    if b.get("max") is not None:
        parts.append(f"{sig} <= {_number(b['max'], 'bounds.max', where)!r}")
    if not parts:
        raise RequirementError(f"{where}bounds needs min, max or both")
    if len(parts) == 2 and b["min"] > b["max"]:
        raise RequirementError(f"{where}bounds: min {b['min']} is above max {b['max']}")
    return f"always{_interval(b, where)} ({' and '.join(parts)})"


def _expand_response(r, where: str) -> str:
    if not isinstance(r, dict) or set(r) - _RESPONSE or not {"trigger", "response", "within"} <= set(r):
        raise RequirementError(f"{where}response is a mapping of trigger, response, within (and hold, from, to) "
                               f"(got {r!r:.80})")
    within = _number(r["within"], "response.within", where)
    hold = _number(r.get("hold", 0.0), "response.hold", where)
    if within < 0 or hold < 0:
        raise RequirementError(f"{where}response: within and hold are durations, >= 0 s")
    for key in ("trigger", "response"):
        if not isinstance(r[key], str):
            raise RequirementError(f"{where}response.{key} must be an STL formula (text)")
        try:  # a whole formula on its own before it is spliced in: unbalanced parentheses would change the expansion
            parse(r[key])
        except StlError as err:
            raise RequirementError(f"{where}response.{key}: {err}") from None
    held = f"always[0:{number_text(hold)}] ({r['response']})" if hold > 0 else f"({r['response']})"
    return f"always{_interval(r, where)} (({r['trigger']}) implies eventually[0:{number_text(within)}] {held})"


def parse_entries(data, where: str) -> list[Requirement]:
    """The requirements of a file's parsed content."""
    if not isinstance(data, dict) or not isinstance(data.get("requirements"), list) or set(data) - {"requirements"}:
        raise RequirementError(f"{where}a requirement file is a mapping with one key, requirements: a list of requirements")
    out: list[Requirement] = []
    seen: set[str] = set()
    for k, entry in enumerate(data["requirements"], 1):
        here = f"{where}requirement {k}: "
        if not isinstance(entry, dict):
            raise RequirementError(f"{here}a mapping of name, description, source and formula | bounds | response")
        unknown = set(entry) - _KEYS
        if unknown:
            raise RequirementError(f"{here}unknown key {sorted(unknown)[0]!r} (known: {', '.join(sorted(_KEYS))})")
        name = entry.get("name")
        if name is None:
            raise RequirementError(f"{here}no name")
        if name in seen:
            raise RequirementError(f"{where}requirement '{name}' is named twice")
        seen.add(name)
        kinds = [key for key in ("formula", "bounds", "response") if key in entry]
        if len(kinds) != 1:
            raise RequirementError(f"{where}requirement '{name}': give exactly one of formula, bounds, response")
        inner = f"{where}requirement '{name}': "
        kind = kinds[0]
        text = (entry["formula"] if kind == "formula" else _expand_bounds(entry["bounds"], inner) if kind == "bounds"
                else _expand_response(entry["response"], inner))
        for key in ("description", "source"):
            if not isinstance(entry.get(key, ""), str):
                raise RequirementError(f"{inner}{key} is text")
        out.append(requirement(name, text, where, entry.get("description", ""), entry.get("source", ""),
                               "" if kind == "formula" else kind))
    if not out:
        raise RequirementError(f"{where}no requirements")
    return out


def load(path: Path) -> list[Requirement]:
    """A requirement file (YAML, or JSON: YAML reads it), read as every user file is (engine/user_files.py)."""
    from ..user_files import UserFileError, read_yaml

    try:
        data = read_yaml(Path(path), MAX_BYTES)
    except UserFileError as err:
        raise RequirementError(str(err)) from None
    return parse_entries(data, f"{path}: ")


def check_horizons(reqs: list[Requirement], span: float, what: str) -> None:
    """Every requirement can be decided by a run of `span` s: one that looks further ahead (always[0:1e308]) is refused
    before it runs, as `tiltload check` refuses it for its logs."""
    for req in reqs:
        if req.horizon > span + 1e-9:
            raise RequirementError(f"requirement '{req.name}' looks {req.horizon:g} s ahead, longer than {what} ({span:g} s): "
                                   "no such run can decide it")


def check_signals(reqs: list[Requirement], available: dict[str, str], where: str) -> None:
    """Every signal a requirement reads is among the available ones (name -> kind: "number" or what it is instead)."""
    for req in reqs:
        for name in req.signals:
            kind = available.get(name)
            if kind is None:
                near = difflib.get_close_matches(name, list(available), n=3, cutoff=0.6)
                hint = f"; did you mean {' or '.join(near)}?" if near else ""
                raise RequirementError(f"requirement '{req.name}': no signal {name} in {where}{hint}")
            if kind != "number":
                raise RequirementError(f"requirement '{req.name}': {name} in {where} is {kind}, not a number")

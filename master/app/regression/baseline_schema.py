"""What every baseline carries, checked one way for each format (a signal baseline's Parquet header, a metrics
baseline's JSON): the case record "run", the FMUs' record "fmus", the signals' "units", the tolerances, and the names of
signals and metrics. One schema per record; a file that breaks one is one line naming the file and the place.

Why bounds on sizes as well as types: the records are copied into reports and compared key by key, so a baseline of
a million keys or a megabyte name would cost far more than the comparison it is for; the bounds are far above what
tiltload writes (a run record holds about 15 keys, an fmus record a few hundred).
"""

from __future__ import annotations

from ...engine.errors import DescriptionError
from ...engine.user_files import UserFileError, check_values, schema_problem

MAX_TEXT = 4096  # characters of one recorded value (a path, a --set list)
MAX_NAME = 256  # characters of a key or a signal's name
MAX_KEYS = 10_000  # entries of one record (every FMU's parameters)
# instance.variable: an instance without a dot, a variable (FMI's structured names may hold dots); no control characters
SIGNAL_NAME = {"type": "string", "maxLength": MAX_NAME, "pattern": r"^[^.\x00-\x1f\x7f]+\.[^\x00-\x1f\x7f]+$"}
_KEY = {"maxLength": MAX_NAME, "pattern": r"^[^\x00-\x1f\x7f]+$"}
_SCALAR = {"anyOf": [{"type": "string", "maxLength": MAX_TEXT}, {"type": "number"}, {"type": "boolean"}]}
RUN = {"type": "object", "maxProperties": 256, "propertyNames": _KEY, "additionalProperties": _SCALAR}
FMUS = {"type": "object", "maxProperties": MAX_KEYS, "propertyNames": _KEY,
        "additionalProperties": {"type": "string", "maxLength": MAX_TEXT}}
UNITS = {"type": "object", "maxProperties": MAX_KEYS, "propertyNames": SIGNAL_NAME,
         "additionalProperties": {"type": "string", "maxLength": 64}}
_TUBE = {"type": "object", "additionalProperties": False,
         "properties": {k: {"type": "number", "minimum": 0} for k in ("abs", "rel", "lead", "lag")}}
TOLERANCES = {"type": "object", "additionalProperties": False,
              "properties": {"default": _TUBE, "signals": {"type": "object", "maxProperties": MAX_KEYS,
                                                           "propertyNames": SIGNAL_NAME, "additionalProperties": _TUBE}}}


def checked(data: object, schema: dict, where: str, what: str) -> dict:
    """data if it fits the schema (every number finite, nesting bounded, then the schema); else one line: "WHERE is not
    WHAT: PLACE: PROBLEM"."""
    try:
        check_values(data, "")
    except UserFileError as err:
        raise DescriptionError(f"{where} is not {what}: {str(err).removeprefix(': ')}") from None
    problem = schema_problem(data, schema, limit=120)
    if problem:  # a pattern's regular expression said in words
        for pattern, words in ((SIGNAL_NAME["pattern"], "is not named instance.variable (plant.x, controller.f_R)"),
                               (_KEY["pattern"], "is empty or holds a control character")):
            problem = problem.replace(f"does not match {pattern!r}", words)
        raise DescriptionError(f"{where} is not {what}: {_printable(problem)}")
    return data


def _printable(text: str) -> str:
    """A schema message quotes the value: control characters in it (a newline) would split the one line."""
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)

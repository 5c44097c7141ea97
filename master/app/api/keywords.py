"""Keyword options of the API as the command line they stand for: one option of `tiltload <command>` per keyword,
parsed and checked by the command's own parser (no second implementation of the options)."""

from __future__ import annotations

import argparse
import difflib
import shlex
from collections.abc import Mapping, Sequence
from pathlib import Path

from .errors import TiltloadError, as_tiltload_errors, raising_parser_class


def subparser(command: str) -> argparse.ArgumentParser:
    """The parser of `tiltload <command>`, raising its usage errors."""
    from ..cli import parser

    root = parser(raising_parser_class())
    sub = next(a for a in root._actions if isinstance(a, argparse._SubParsersAction))
    return sub.choices[command]


def options_of(command: str) -> dict[str, argparse.Action]:
    """The keyword each option of `tiltload <command>` takes (its dest: --stop-time is stop_time), and its action."""
    return {a.dest: a for a in subparser(command)._actions if a.option_strings and a.dest != "help"}


def _flag(action: argparse.Action) -> str:
    return max(action.option_strings, key=len)


def _token(flag: str, value: object) -> list[str]:
    text = str(value)
    return [f"{flag}={text}"] if text.startswith("-") else [flag, text]  # a value like -1 is no option


def to_argv(command: str, options: Mapping[str, object], function: str) -> list[str]:
    """The command line of the keywords (None: the option's default). An unknown keyword is a TypeError, as any Python
    function's; a value of the wrong kind for a flag or a repeated option is a TiltloadError naming the option."""
    actions = options_of(command)
    argv: list[str] = []
    for key, value in options.items():
        if key not in actions:
            close = difflib.get_close_matches(key, actions, n=1)
            raise TypeError(f"{function}() got an unexpected keyword argument {key!r}"
                            + (f" (did you mean {close[0]!r}?)" if close else f"; the options are {', '.join(actions)}"))
        action, flag = actions[key], _flag(actions[key])
        if value is None:
            continue
        if isinstance(action, (argparse._StoreTrueAction, argparse._StoreFalseAction)):
            if not isinstance(value, bool):
                raise TiltloadError(f"argument {flag}: a flag takes True or False, got {value!r}")
            argv += [flag] * (value is not getattr(action, "default", False))
        elif isinstance(action, argparse._AppendAction):
            items = value.items() if isinstance(value, Mapping) else [value] if isinstance(value, str) else value
            for item in items:
                argv += _token(flag, item if isinstance(item, str) else "=".join(map(str, item)))
        elif action.nargs == "?":  # --realtime [FACTOR]: True alone, a number with it
            if value is True:
                argv.append(flag)
            elif value is not False:
                argv += _token(flag, value)
        elif isinstance(action.nargs, int):  # --snapshot-at T FILE
            if isinstance(value, (str, bytes)) or not isinstance(value, Sequence) or len(value) != action.nargs:
                raise TiltloadError(f"argument {flag}: takes {action.nargs} values ({' '.join(action.metavar or ())}), "
                                    f"got {value!r}")
            argv += [flag, *map(str, value)]
        else:
            argv += _token(flag, Path(value).as_posix() if isinstance(value, Path) else value)
    return argv


def parse(command: str, argv: list[str]) -> argparse.Namespace:
    """The namespace `tiltload <command> ARGV` runs with; its usage errors as TiltloadError (the CLI's line)."""
    from ..cli import parser

    with as_tiltload_errors():
        return parser(raising_parser_class()).parse_args([command, *argv])


def command_line(command: str, argv: list[str]) -> str:
    """The shell command that does the same."""
    return shlex.join(["tiltload", command, *argv])

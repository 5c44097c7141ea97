"""A request object (Case, RunOptions, CampaignOptions, FalsifyOptions) as the command line that gives the same
request: each field that differs from its default as its option (the field's name with dashes)."""

from __future__ import annotations

import shlex
from dataclasses import fields, replace
from pathlib import Path


def text_of(value: object) -> str:
    """A value as the command line writes it (and reads it back: loop.parse_value)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    return repr(value) if isinstance(value, float) else str(value)  # 1.0 stays a float when read back


def _number(value: float) -> str:
    return str(int(value)) if float(value).is_integer() and abs(value) < 1e16 else repr(value)


def options_argv(request: object) -> list[str]:
    """The options of a request object (Case, RunOptions) that differ from its defaults, as the command line that
    gives them: --stop-time 3, a flag alone, --set once per parameter."""
    argv: list[str] = []
    for f in fields(request):
        value, flag = getattr(request, f.name), "--" + f.name.replace("_", "-")
        if value == f.default:
            continue
        if value is True:
            argv.append(flag)
        elif f.name in ("set", "remote", "expect_fmu"):
            for key, item in value:
                argv += _option(flag, f"{key}={text_of(item)}")
        elif isinstance(value, tuple):  # --snapshot-at T FILE
            argv += [flag, *(_number(v) if isinstance(v, (int, float)) else str(v) for v in value)]
        else:
            argv += _option(flag, _number(value) if isinstance(value, float) else
                            Path(value).as_posix() if isinstance(value, Path) else str(value))
    return argv


def _option(flag: str, text: str) -> list[str]:
    return [f"{flag}={text}"] if text.startswith("-") else [flag, text]  # a value like -1 is no option



def run_command(case: object, options: object) -> str:
    """The `tiltload run` command that makes the same run (quiet and the report aside: they change no run)."""
    return shlex.join(["tiltload", "run", *options_argv(case), *options_argv(replace(options, quiet=False, report=None))])

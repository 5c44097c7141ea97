"""The one exception class of the public API: what the user can fix, with the line the `tiltload` command prints."""

from __future__ import annotations

import argparse
from collections.abc import Iterator
from contextlib import contextmanager


class TiltloadError(Exception):
    """A problem the user can fix: a bad option, file, spec or baseline, two different cases compared, a run that
    ended early. ``str(err)`` is the message; ``err.cli_line`` is the line the `tiltload` command prints for it."""

    def __init__(self, message: str, cli_line: str | None = None) -> None:
        super().__init__(message)
        self.cli_line = cli_line if cli_line is not None else f"tiltload: error: {message}"


class _UsageError(Exception):
    def __init__(self, prog: str, message: str) -> None:
        super().__init__(message)
        self.prog = prog


def raising_parser_class() -> type[argparse.ArgumentParser]:
    """The CLI's parser class with its usage errors raised, not printed with an exit."""
    from ..cli import OneLineParser

    class RaisingParser(OneLineParser):
        def error(self, message: str):  # type: ignore[override]
            raise _UsageError(self.prog, message)
    return RaisingParser


@contextmanager
def as_tiltload_errors() -> Iterator[None]:
    """Inside: the errors the `tiltload` command reports in one line (exit 2, or a failed build) become TiltloadError."""
    from ....native_fmu.compile import BuildError
    from ..errors import USER_ERRORS

    try:
        yield
    except _UsageError as err:
        from ..cli import OneLineParser

        raise TiltloadError(str(err), OneLineParser.usage_line(err.prog, str(err))) from None
    except USER_ERRORS as err:
        raise TiltloadError(str(err)) from None
    except BuildError as err:
        raise TiltloadError(f"building the FMUs failed: {err}") from None

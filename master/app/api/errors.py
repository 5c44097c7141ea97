"""The one exception class of the public API (what the user can fix, with the line the `tiltload` command prints), and
the other errors the command reports in one line turned into it."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

from ..user_error import TiltloadError, usage_error

__all__ = ["TiltloadError", "as_tiltload_errors", "usage_error"]


@contextmanager
def as_tiltload_errors() -> Iterator[None]:
    """Inside: the errors the `tiltload` command reports in one line (exit 2, or a failed build) become TiltloadError."""
    from ..errors import kind_of

    try:
        yield
    except TiltloadError:
        raise
    except Exception as err:
        kind = kind_of(err)  # the one table of errors (errors.py), as the command classifies them
        if kind is None:
            raise
        raise TiltloadError(f"{kind.prefix}{err}", exit_code=kind.exit_code) from None

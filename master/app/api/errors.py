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
    from ....native_fmu.compile import BuildError
    from ..errors import USER_ERRORS

    try:
        yield
    except TiltloadError:
        raise
    except USER_ERRORS as err:
        raise TiltloadError(str(err)) from None
    except BuildError as err:
        raise TiltloadError(f"building the FMUs failed: {err}") from None

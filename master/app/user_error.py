"""The error a user can fix (one line, exit 2), in a module of its own: any module of the application may raise it,
the option parsing included, without importing errors.py's gathering of every error kind."""

from __future__ import annotations


class UserError(Exception):
    """A problem the user can fix; reported as one line, exit code 2."""

"""The error a user can fix (one line, exit 2), in a module of its own: any module of the application may raise it,
the option parsing included, without importing errors.py's gathering of every error kind."""

from __future__ import annotations

_ESCAPES = {"\n": "\\n", "\r": "\\r", "\t": "\\t"}


def one_line(text: str) -> str:
    """text with its control characters and line separators shown as escapes (\\n, \\x1b): a user's value quoted into
    an error (a name with a newline, a terminal's escape sequence) cannot split the line or act on the terminal."""
    import unicodedata

    if text.isprintable():
        return text
    return "".join(_ESCAPES.get(c) or (f"\\x{ord(c):02x}" if ord(c) < 0x100 else f"\\u{ord(c):04x}")
                   if unicodedata.category(c) in ("Cc", "Zl", "Zp") else c for c in text)


class TiltloadError(Exception):
    """A problem the user can fix: a bad option, file, spec or baseline, two different cases compared, a run that
    ended early. ``str(err)`` is the message; ``err.cli_line`` is the line the `tiltload` command prints for it (exit 2).
    Public as tiltload.TiltloadError."""

    def __init__(self, message: str, cli_line: str | None = None, exit_code: int = 2) -> None:
        message = one_line(message)
        super().__init__(message)
        self.cli_line = one_line(cli_line) if cli_line is not None else f"tiltload: error: {message}"
        self.exit_code = exit_code  # 2: the user's to fix; 1: a build that failed (errors.KINDS)


class UserError(TiltloadError):
    """A problem the user can fix, raised by the application's own checks; reported as one line, exit code 2."""

    def __init__(self, message: str) -> None:
        super().__init__(message)


def usage_error(command: str, message: str) -> TiltloadError:
    """A bad option's value as `tiltload COMMAND` says it when its parser refuses it (the usage line, exit 2)."""
    prog = f"tiltload {command}"
    return TiltloadError(message, f"{prog}: error: {message} (see: {prog} --help)")

"""The error a user can fix (one line, exit 2), in a module of its own: any module of the application may raise it,
the option parsing included, without importing errors.py's gathering of every error kind."""

from __future__ import annotations

_ESCAPES = {"\n": "\\n", "\r": "\\r", "\t": "\\t"}
# bidirectional-text controls: embeddings, overrides, isolates and marks reorder what a reader sees ("Trojan Source",
# CVE-2021-42574), so that a name or description could read as something it is not
BIDI = "\u202a\u202b\u202c\u202d\u202e\u2066\u2067\u2068\u2069\u200e\u200f\u061c"
_VISIBLE = str.maketrans({c: f"\\u{ord(c):04x}" for c in BIDI})


def one_line(text: str) -> str:
    """text with its control characters, line separators and bidirectional controls shown as escapes (\\n, \\x1b,
    \\u202e): a user's value quoted into an error (a name with a newline, a terminal's escape sequence) cannot split the
    line, act on the terminal or read as something it is not."""
    import unicodedata

    if text.isprintable() and not any(c in BIDI for c in text):
        return text
    return "".join(_ESCAPES.get(c) or (f"\\x{ord(c):02x}" if ord(c) < 0x100 else f"\\u{ord(c):04x}")
                   if unicodedata.category(c) in ("Cc", "Zl", "Zp") or c in BIDI else c for c in text)


def visible(value):
    """User text in what tiltload shows (the HTML reports, the pytest plugin's messages) with each bidirectional control
    written as its escape; markup (an object with __html__, jinja2's Markup) kept markup; anything else as it is."""
    if hasattr(value, "__html__"):
        return type(value)(str(value).translate(_VISIBLE))
    return value.translate(_VISIBLE) if isinstance(value, str) else value


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

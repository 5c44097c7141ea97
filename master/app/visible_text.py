"""User text in what tiltload shows (the HTML reports, the pytest plugin's failure messages) with each bidirectional-text
control written as its escape (\\u202e): embeddings, overrides, isolates and marks reorder what a reader sees ("Trojan
Source", CVE-2021-42574), so that a name or description could read as something it is not."""

from __future__ import annotations

BIDI = "\u202a\u202b\u202c\u202d\u202e\u2066\u2067\u2068\u2069\u200e\u200f\u061c"
_VISIBLE = str.maketrans({c: f"\\u{ord(c):04x}" for c in BIDI})


def visible(value):
    """Text with each bidirectional control shown as its escape; markup (an object with __html__, jinja2's Markup) kept
    markup; anything else as it is."""
    if hasattr(value, "__html__"):
        return type(value)(str(value).translate(_VISIBLE))
    return value.translate(_VISIBLE) if isinstance(value, str) else value

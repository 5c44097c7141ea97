"""Tests that need a shared library of the system (not a Python package): skipped, with one line naming the library
and how to get it, where the dynamic loader cannot load it. The README's set-up names the same libraries."""

from __future__ import annotations

import ctypes

import pytest

# soname -> how to get it; the README's set-up section says the same
LIBRARIES = {"libtbb.so.12": "Debian/Ubuntu: apt-get install libtbb12; ecospy, the Ecos master, links it"}


def loadable(soname: str) -> bool:
    try:
        ctypes.CDLL(soname)
    except OSError:
        return False
    return True


def needs_library(soname: str, how: str | None = None) -> pytest.MarkDecorator:
    """skipif the loader cannot load soname, the reason naming it and how to get it (LIBRARIES, unless how)."""
    return pytest.mark.skipif(not loadable(soname), reason=f"needs the system library {soname} ({how or LIBRARIES[soname]})")

"""Argument types shared by every command line of the project (`tiltload`, and `tiltload serve` run alone on a board that
has only the engine's dependencies): standard library only.

Every time a command waits is bounded where it is parsed: a wait handed to a socket, a thread or a C clock overflows far
below what a float holds (1e12 s is "timestamp too large"), and no wait in tiltload is meant to last past a day. Each
option's help names its bound (`span_help`)."""

from __future__ import annotations

import argparse
import math

DAY = 86400.0  # s: the longest wait any option allows (a session idle for a day, a watchdog of a day)


def time_span(high: float, what: str = "time"):
    """An argparse type: a positive finite number of seconds, at most high."""
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if not (0 < value <= high):
            raise argparse.ArgumentTypeError(f"must be a positive {what} in s, at most {high:g}, got {text}")
        return value
    return parse


def _positive_finite(text: str, what: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (value > 0 and math.isfinite(value)):
        raise argparse.ArgumentTypeError(f"must be a positive finite {what}, got {text}")
    return value


def positive_number(text: str) -> float:
    """An argparse type: a positive finite number."""
    return _positive_finite(text, "number")


def positive_time(text: str) -> float:
    """An argparse type: a positive finite time in s (a span a run covers, not a wait: see time_span)."""
    return _positive_finite(text, "time in s")


def integer(low: int, high: int | None = None):
    """An argparse type: a whole number in [low, high] (no upper bound if high is None)."""
    what = f"a whole number from {low} to {high}" if high is not None else f"a whole number >= {low}"

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be {what}, got {text}") from None
        if value < low or (high is not None and value > high):
            raise argparse.ArgumentTypeError(f"must be {what}, got {text}")
        return value
    return parse


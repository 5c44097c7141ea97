"""Argument types shared by every command line of the project (`tiltload`, and `tiltload serve` run alone on a board that
has only the engine's dependencies): standard library only.

Every time a command waits is bounded where it is parsed: a wait handed to a socket, a thread or a C clock overflows far
below what a float holds (1e12 s is "timestamp too large"), and no wait in tiltload is meant to last past a day. Each
option's help names its bound (`span_help`)."""

from __future__ import annotations

import argparse
import math

DAY = 86400.0  # s: the longest wait any option allows (a session idle for a day, a watchdog of a day)


def real_in(accepts, what: str):
    """An argparse type: a number accepts(value) holds for, else "must be {what}, got TEXT". Text that is no number reads
    as NaN, which every range refuses with that same line."""
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if not accepts(value):
            raise argparse.ArgumentTypeError(f"must be {what}, got {text}")
        return value
    return parse


def time_span(high: float, what: str = "time"):
    """An argparse type: a positive finite number of seconds, at most high."""
    return real_in(lambda value: 0 < value <= high, f"a positive {what} in s, at most {high:g}")


def _finite_above_zero(value: float) -> bool:
    return value > 0 and math.isfinite(value)


positive_number = real_in(_finite_above_zero, "a positive finite number")
# a span a run covers, not a wait (time_span)
positive_time = real_in(_finite_above_zero, "a positive finite time in s")
# the longest a run may cover: 11.6 days of simulated time, 83 million ticks (hours of wall time at the loop's speed);
# the feasibility check and the log are sized by it, so 1e300 is refused rather than iterated over
MAX_RUN = 1e6
run_time = real_in(lambda value: 0 < value <= MAX_RUN, f"a positive time in s, at most {MAX_RUN:g}")
tolerance = real_in(lambda value: math.isfinite(value) and value >= 0, "a finite number >= 0")


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


"""Assertions for tests of a controller (the pytest plugin's fixtures use them): docs/api.md."""

from __future__ import annotations

from .master.app.testing.assertions import (
    TiltloadAssertionError,
    assert_matches_baseline,
    assert_metrics_below,
    assert_requirements_hold,
    assert_signals_match,
)

__all__ = ["TiltloadAssertionError", "assert_matches_baseline", "assert_metrics_below", "assert_requirements_hold", "assert_signals_match"]

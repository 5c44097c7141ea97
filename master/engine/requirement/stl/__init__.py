"""Signal Temporal Logic monitors: rtamt's textual grammar (syntax), discrete-time robustness (robustness) with O(n)
windowed min/max (windows). Generic: it knows nothing of FMUs, logs or tiltload; docs/requirements.md."""

from .robustness import FAIL, INCONCLUSIVE, PASS, ZERO, Evaluator, Trace, Verdict, verdict
from .syntax import StlError, bounded_horizon, horizon, parse, signals, unparse

__all__ = ["FAIL", "INCONCLUSIVE", "PASS", "ZERO", "Evaluator", "StlError", "Trace", "Verdict", "bounded_horizon", "horizon",
           "parse", "signals", "unparse", "verdict"]

"""Signal Temporal Logic monitors: the syntax tree and its walks (syntax), rtamt's textual grammar (grammar),
discrete-time robustness (robustness) with O(n) windowed min/max (windows), a formula's verdict at a trace's start
(verdicts). Generic: it knows nothing of FMUs, logs or tiltload; docs/requirements.md."""

from .grammar import parse, unparse
from .robustness import Evaluator, Trace
from .syntax import StlError, bounded_horizon, horizon, signals
from .verdicts import FAIL, INCONCLUSIVE, PASS, ZERO, Verdict, decided_fail, reads_from, verdict

__all__ = ["FAIL", "INCONCLUSIVE", "PASS", "ZERO", "Evaluator", "StlError", "Trace", "Verdict", "bounded_horizon",
           "decided_fail", "horizon", "parse", "reads_from", "signals", "unparse", "verdict"]

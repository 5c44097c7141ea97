"""Requirement verdicts as the table `tiltload run --requirements` and `tiltload check` print."""

from __future__ import annotations

import math


def _fmt(x: float | None) -> str:
    if x is None:
        return "-"
    return f"{x:.6g}" if math.isfinite(x) else "nan" if math.isnan(x) else ("inf" if x > 0 else "-inf")


def table(results) -> list[str]:
    """One line per requirement: name, verdict, robustness, first violation, the signals' values there."""
    width = max([11] + [len(r.name) for r in results])
    lines = [f"  {'requirement':<{width}}  {'verdict':<14} {'robustness':>12}  {'first violation':<16} values there"]
    for r in results:
        rob = _fmt(r.robustness) if r.robustness is not None else (f"<= {_fmt(r.bounds[1])}" if r.verdict == "FAIL" else "-")
        rob = f">= {rob}" if r.robustness is not None and r.why and r.verdict == "PASS" else rob  # a lower bound (NaN there)
        at = f"t = {r.first_violation:.3f} s" if r.first_violation is not None else ""
        there = ", ".join(f"{k} = {v:.6g}" for k, v in r.values.items()) or r.why
        lines.append(f"  {r.name:<{width}}  {r.shown:<14} {rob:>12}  {at:<16} {there}".rstrip())
    return lines

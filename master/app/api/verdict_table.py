"""Requirement verdicts as the table `tiltload run --requirements` and `tiltload check` print."""

from __future__ import annotations

import math


def _fmt(x: float | None) -> str:
    if x is None:
        return "-"
    return f"{x:.6g}" if math.isfinite(x) else ("inf" if x > 0 else "-inf")


def table(results) -> list[str]:
    """One line per requirement: name, verdict, robustness, first violation, the signals' values there."""
    width = max([11] + [len(r.name) for r in results])
    lines = [f"  {'requirement':<{width}}  {'verdict':<12} {'robustness':>12}  {'first violation':<16} values there"]
    for r in results:
        rob = _fmt(r.robustness) if r.robustness is not None else (f"<= {_fmt(r.bounds[1])}" if r.verdict == "FAIL" else "-")
        at = f"t = {r.first_violation:.3f} s" if r.first_violation is not None else ""
        there = ", ".join(f"{k} = {v:.6g}" for k, v in r.values.items()) or r.why
        lines.append(f"  {r.name:<{width}}  {r.verdict:<12} {rob:>12}  {at:<16} {there}".rstrip())
    return lines

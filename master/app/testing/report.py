"""Failure messages that read like a test report: which metric differs from the baseline, by how much, against which
tolerance; the command that reruns the case."""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path

from ..case.record import describe as case_words
from ..regression.compare import Comparison
from ..user_error import visible


def _signed(x: float) -> str:
    return f"{x:+.4g}"


def baseline_report(comparison: Comparison, case: Mapping[str, str], command: str, baseline: Path | str,
                    what: str = "the run", update_hint: str | None = None) -> str:
    """The message of a run that differs from its baseline (comparison.ok is False)."""
    bad = [r for r in comparison.rows if r.status != "ok"]
    good = [r.metric for r in comparison.rows if r.status == "ok"]
    width = max(len(r.metric) for r in bad)
    counted = f"{len(bad)} of {len(comparison.rows)} metrics out of tolerance"
    if comparison.changes:  # what changed in the controller (or any FMU) first, then what it did to the metrics
        lines = [f"{what} differs from its baseline; {comparison.changed_line()}", f"  {counted}"]
    else:
        lines = [f"{what} differs from its baseline: {counted}"]
    lines += [f"  case:     {case_words(case)}", f"  baseline: {baseline}"]
    for r in bad:
        if r.status == "MISSING":
            lines.append(f"    {r.metric:<{width}}  missing from the run (baseline {r.baseline:.6g})")
            continue
        change = r.run - r.baseline
        rel = f"{100 * change / abs(r.baseline):+.3g} %" if r.baseline else "from 0"
        allowed = r.atol + r.rtol * abs(r.baseline)
        lines.append(f"    {r.metric:<{width}}  run {r.run:.6g}  baseline {r.baseline:.6g}  change {_signed(change)} ({rel}); "
                     f"allowed +/-{allowed:.3g} (rtol {r.rtol:g}, atol {r.atol:g})")
    if good:
        lines.append(f"  within tolerance: {', '.join(good)}")
    lines += [f"  note: {n}" for n in comparison.notes]
    lines.append(f"  rerun:    {command}")
    if update_hint:
        lines.append(f"  if the change is intended, record the new baseline: {update_hint}")
    return visible("\n".join(lines))


def limits_report(metrics: Mapping[str, float], limits: Mapping[str, float], case: Mapping[str, str], command: str,
                  what: str = "the run") -> str | None:
    """The message of metrics above their limits (None if all are within them)."""
    over = [(k, metrics.get(k, math.nan), lim) for k, lim in limits.items()
            if not (metrics.get(k, math.nan) <= lim)]
    if not over:
        return None
    width = max(len(k) for k, _, _ in over)
    lines = [f"{what}: {len(over)} of {len(limits)} metrics above their limits", f"  case:  {case_words(case)}"]
    for k, v, lim in over:
        lines.append(f"    {k:<{width}}  missing from the run" if math.isnan(v) else
                     f"    {k:<{width}}  {v:.6g} > limit {lim:.6g} (by {v - lim:.4g}, {100 * (v - lim) / abs(lim):.3g} %)"
                     if lim else f"    {k:<{width}}  {v:.6g} > limit {lim:g}")
    lines.append(f"  rerun: {command}")
    return visible("\n".join(lines))


def requirements_report(results, case: Mapping[str, str], command: str, what: str = "the run") -> str | None:
    """The message of requirements that do not hold (FAIL, or undecided: INCONCLUSIVE, ZERO); None if all PASS."""
    bad = [r for r in results if r.verdict != "PASS"]
    if not bad:
        return None
    width = max(len(r.name) for r in bad)
    lines = [f"{what}: {len(bad)} of {len(results)} requirements do not hold", f"  case:  {case_words(case)}"]
    for r in bad:
        if r.verdict == "FAIL":
            at = ", ".join(f"{k} = {v:.6g}" for k, v in r.values.items())
            rob = f"robustness {r.robustness:.6g}" if r.robustness is not None else f"robustness at most {r.bounds[1]:.6g}"
            lines.append(f"    {r.name:<{width}}  FAIL, {rob}; first violated at t = {r.first_violation:.6g} s ({at})")
        else:
            lines.append(f"    {r.name:<{width}}  {r.verdict}" + (f": {r.why}" if r.why else ""))
        lines.append(f"    {'':<{width}}  {r.formula}")
    lines.append(f"  rerun: {command}")
    return visible("\n".join(lines))

"""A figure of each signal outside its tolerance tube: the band, the reference, the candidate, where it left first."""

from __future__ import annotations

import re
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def tube_figures(rows, out: Path, stem: str, title: str = "") -> list[Path]:
    """<out>/<stem>_tube_<signal>.png for each failing row (signal_compare.SignalRow); the files written."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    files = []
    for row in rows:
        if row.passed or row.tube is None:
            continue
        tb, (t_ref, y_ref) = row.tube, row.reference
        fig, (ax, dev) = plt.subplots(2, 1, figsize=(8, 5.4), sharex=True, height_ratios=(3, 2))
        finite = np.isfinite(tb.lower) & np.isfinite(tb.upper)
        lower, upper = np.where(finite, tb.lower, np.nan), np.where(finite, tb.upper, np.nan)
        # the reference held at the check points: the lower panel shows the tube and the run relative to it, where a
        # narrow tube is visible
        held = y_ref[np.maximum(np.searchsorted(t_ref, tb.time, side="right") - 1, 0)]
        for axis, shift in ((ax, 0.0), (dev, held)):
            axis.fill_between(tb.time, lower - shift, upper - shift, step="post", color="C0", alpha=0.3, lw=0, label="tube")
            axis.step(tb.time, tb.value - shift, where="post", color="C3", lw=0.9, label="run")
            axis.axvline(row.first_outside, color="k", ls="--", lw=0.7, label=f"first outside, t = {row.first_outside:.4g} s")
        ax.step(t_ref, y_ref, where="post", color="C0", lw=0.8, label="reference")
        bad = tb.outside & np.isfinite(tb.value)
        dev.plot(tb.time[bad], (tb.value - held)[bad], ".", color="C3", ms=2, label="outside")
        unit = f" ({row.unit})" if row.unit and row.unit != "1" else ""
        dev.set_xlabel("t (s)")
        ax.set_ylabel(f"{row.signal}{unit}")
        dev.set_ylabel(f"minus the reference{unit}", fontsize=8)
        ax.legend(fontsize=7, loc="best")
        ax.set_title(f"{row.signal} outside its tube ({row.tolerance.words()})" + (f"\n{title}" if title else ""), fontsize=9)
        fig.tight_layout()
        path = out / f"{stem}_tube_{re.sub(r'[^A-Za-z0-9_.-]', '_', row.signal)}.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        files.append(path)
    return files

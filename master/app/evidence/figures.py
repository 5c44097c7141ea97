"""A report's figures, inline: each requirement's signals and its margin with the bound drawn and the violations
shaded (SVG, decimated by envelope: every extreme kept), and the run's standard figures (PNG as data: URIs)."""

from __future__ import annotations

import base64
import io
import textwrap
from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ..views.plot import scale_to_sane  # noqa: E402
from .decimate import envelope  # noqa: E402

COLUMNS = 800  # pixel columns of a figure's plot area (10 in at 96 dpi, less the margins): the decimation's resolution


@dataclass
class Curve:
    """One decimated line of a figure, as the page's data holds it (times in s)."""

    label: str
    times: list[float]
    values: list[float | None]  # None: not finite (JSON has no NaN)


def decimated(label: str, times: np.ndarray, values: np.ndarray) -> Curve:
    keep = envelope(times, values, COLUMNS)
    v = values[keep]
    return Curve(label, [_short(t) for t in times[keep]], [_short(x) if np.isfinite(x) else None for x in v])


def _short(x) -> float:
    """7 significant digits: far finer than a pixel, half the page's text."""
    return float(f"{float(x):.7g}")


def _finite_until(times: np.ndarray, values: np.ndarray) -> float | None:
    """The time of the first non-finite sample (a divergence), or None."""
    bad = np.flatnonzero(~np.isfinite(values))
    return float(times[bad[0]]) if len(bad) else None


def requirement_figure(req, trace, result, unit_of, final: bool = True) -> tuple[str, list[Curve]]:
    """(inline SVG, the curves drawn) of one requirement on its trace: its signals, a panel per unit (a reference and
    what follows it share one), the first violation marked; and its margin (for always[a:b] φ, φ's robustness over the
    window) against the bound 0, violations shaded. A diverged signal is drawn where it was finite, its divergence
    marked."""
    from ...engine.requirement.check import intervals, margins

    times, margin = margins(req, trace, final=final)
    panels: dict[str, list[str]] = {}
    for name in req.signals:
        panels.setdefault(unit_of(name), []).append(name)
    fig, axes = plt.subplots(len(panels) + 1, 1, figsize=(10, 1.5 * (len(panels) + 1) + 0.7), sharex=True, squeeze=False)
    curves = []
    bad = intervals(times, margin < 0)
    first = result.first_violation
    for ax, (unit, names) in zip(axes[:-1, 0], panels.items()):
        diverged = []
        for k, name in enumerate(names):
            values = np.asarray(trace.signals[name], dtype=float)
            c = decimated(name, trace.times, values)
            curves.append(c)
            ax.plot(c.times, [np.nan if v is None else v for v in c.values], lw=0.9, color=f"C{k}", label=name)
            diverged.append(_finite_until(trace.times, values))
        ax.set_ylabel(f"({unit})", fontsize=7)
        blown = scale_to_sane(ax)
        curves += _draw_bounds(ax, trace, [b for b in bounds_of(req.formula) if b[0] in names])
        ax.legend(fontsize=6, loc="best", framealpha=0.6)  # a diverged run: scaled to its samples before the divergence, which it marks
        _mark(ax, bad, first, None if blown is not None else min((d for d in diverged if d is not None), default=None))
    ax = axes[-1, 0]
    c = decimated("margin", times, np.asarray(margin, dtype=float))
    curves.append(c)
    ax.plot(c.times, [np.nan if v is None else v for v in c.values], lw=0.9, color="C2", label="margin")
    ax.axhline(0.0, color="k", lw=0.8, ls="--", label="bound (margin 0)")
    # the margin is in its signals' unit when they share one (a bound on a difference of positions: m)
    ax.set_ylabel("margin" + (f" ({next(iter(panels))})" if len(panels) == 1 and next(iter(panels)) != "1" else ""), fontsize=7)
    blown = scale_to_sane(ax)
    _mark(ax, bad, first, None if blown is not None else _finite_until(times, np.asarray(margin, dtype=float)))
    if bad:
        ax.axvspan(0, 0, color="C3", alpha=0.22, lw=0, label="violated")
    ax.legend(fontsize=6, loc="best", framealpha=0.6)
    ax.set_xlabel("t (s)", fontsize=8)
    for a in axes[:, 0]:
        a.tick_params(labelsize=7)
    verdict = getattr(result, "verdict", "")
    # the name and verdict first, the formula in full below, wrapped to the figure's width (about 150 characters at 8 pt)
    title = "\n".join([f"{req.name}: {verdict}", *textwrap.wrap(req.text, 150)])
    fig.suptitle(title, fontsize=8, x=0.01, ha="left")
    fig.tight_layout(rect=(0, 0, 1, 1 - 0.11 * title.count("\n") / fig.get_size_inches()[1]))
    return _svg(fig, req.name), curves


def bounds_of(tree) -> list[tuple[str, float, str | None]]:
    """The bounds a formula puts on a signal, to draw on that signal: (signal, c, None) for `s op c` (a line at c),
    (a, c, b) for `abs(a - b) op c` or `a - b op c` (lines at b ± c: a band around the reference b). Other
    comparisons (a product, two signals' sum) have no bound on one signal: the margin panel shows them."""
    from ...engine.requirement.stl.syntax import Arith, Compare, Const, Signal

    out = []
    if isinstance(tree, Compare):
        side, c = (tree.left, tree.right) if isinstance(tree.right, Const) else (tree.right, tree.left)
        if isinstance(c, Const):
            band = isinstance(side, Arith) and side.op == "abs"
            inner = side.args[0] if band else side
            if isinstance(inner, Signal):
                out.append((inner.name, c.value, None))
            elif isinstance(inner, Arith) and inner.op == "-" and all(isinstance(a, Signal) for a in inner.args):
                a, b = inner.args[0].name, inner.args[1].name
                out += [(a, c.value, b)] + ([(a, -c.value, b)] if band else [])
        return out
    for child in ("arg", "left", "right"):
        if hasattr(tree, child):
            out += bounds_of(getattr(tree, child))
    return out


def _draw_bounds(ax, trace, bounds) -> list[Curve]:
    """Each bound on its signal's panel, dashed red (a band: the reference ± c, decimated as the reference is); the
    curves drawn, labelled "bound on SIGNAL", for the page's data."""
    out = []
    for k, (signal, c, reference) in enumerate(dict.fromkeys(bounds)):
        if reference is None:
            t = [_short(trace.times[0]), _short(trace.times[-1])] if len(trace.times) else []
            curve = Curve(f"bound on {signal}", t, [_short(c)] * len(t))
        elif reference in trace.signals:
            ref = decimated(reference, trace.times, np.asarray(trace.signals[reference], dtype=float))
            curve = Curve(f"bound on {signal}", ref.times, [None if v is None else _short(v + c) for v in ref.values])
        else:
            continue
        ax.plot(curve.times, [np.nan if v is None else v for v in curve.values], color="C3", lw=0.8, ls="--",
                label="bound" if k == 0 else None)
        out.append(curve)
    return out


def _mark(ax, bad, first, diverged) -> None:
    for t0, t1 in bad:
        ax.axvspan(t0, t1 if t1 > t0 else t0 + 1e-3, color="C3", alpha=0.22, lw=0)
    if first is not None:
        ax.axvline(first, color="C3", lw=0.8)
    if diverged is not None:
        ax.axvline(diverged, color="m", lw=1.0, ls=":")
        ax.text(diverged, 0.95, " diverged", transform=ax.get_xaxis_transform(), fontsize=6, color="m", va="top")


def _svg(fig, name: str) -> str:
    buffer = io.StringIO()
    # text stays text (smaller, searchable); the salt keeps element ids apart between the page's figures; no date
    with plt.rc_context({"svg.fonttype": "none", "svg.hashsalt": name}):
        fig.savefig(buffer, format="svg", metadata={"Date": None})
    plt.close(fig)
    text = buffer.getvalue()
    return text[text.index("<svg"):]  # the XML declaration and DOCTYPE do not belong inside HTML


def standard_figures(log: Path) -> list[tuple[str, str]]:
    """(title, PNG data: URI) of the figures `tiltload plot` draws of the log: the thesis's kinds the log allows, or a
    `--system` run's FMUs' outputs (none for a log without a plant or a numeric output)."""
    from ...engine.log import reader as log_reader
    from ..views.plot import TITLES, TOPICS, case_of, figures, is_system_run
    from ..views.system_plot import outputs_figure

    log = Path(log)
    if is_system_run(log):
        data, _ = log_reader.read_checked(log)
        fig = outputs_figure(log, case_of(log), data)
        return [] if fig is None else [("Each FMU's outputs", _png_uri(fig))]
    data, state = log_reader.read_checked(log, topics=TOPICS)
    if not data.get("/plant"):
        return []
    return [(TITLES.get(name, name), _png_uri(fig)) for name, fig in figures(data, case_of(log))]


def _png_uri(fig) -> str:
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=72)
    plt.close(fig)
    return "data:image/png;base64," + base64.b64encode(buffer.getvalue()).decode()

"""A campaign report's figures: the metrics' distributions per controller (a box per controller, or each run as a
point when a controller has fewer than STRIP_BELOW), their units and axis labels."""

from __future__ import annotations

import math

import numpy as np

ISE_POSITION = ("ISE(x)", "ISE(y)", "ISE(z)")
DISTRIBUTIONS = ("ISE(x)", "ISE(y)", "ISE(z)", "max_tracking_error", "IADU(f_R)", "IADU(tau_R)", "time_saturated",
                 "zse_containment")
STRIP_BELOW = 5  # fewer runs than this in a group: each run drawn as a point, not a box of quartiles it cannot have
TITLES = {"max_tracking_error": "largest tracking error", "time_saturated": "time saturated",
          "zse_containment": "truth inside the ZSE's bounds"}


def metric_unit(key: str) -> str:
    """The unit of a campaign metric: ISE of a position in m²·s, of an angle in rad²·s; IADU in its input's unit."""
    from ..views.plot import unit

    if key.startswith(("ISE(", "IADU(")):
        name = key[key.index("(") + 1:-1]
        base = unit(name)
        return f"{base}²·s" if key.startswith("ISE(") else base
    return {"max_tracking_error": "m", "time_saturated": "share of steps",
            "zse_containment": "share of steps"}[key]


def parameter_unit(name: str, spec: dict | None) -> str:
    """A varied parameter's unit, from the model parameter its first target sets (empty when none is known)."""
    from ....plant_fmu.parameters import ACTUATOR_LIMITS, MODEL_PARAMETERS

    for p in (spec or {}).get("vary", {}).get("parameters", []):
        if p.get("name") == name and p.get("targets"):
            leaf = p["targets"][0].split(".")[-1]
            found = next((s.unit for s in (*MODEL_PARAMETERS, *ACTUATOR_LIMITS) if s.name == leaf), "")
            return found.replace(".", " ")
    return ""


def axis_label(name: str, unit: str) -> str:
    return f"{name} ({unit})" if unit and unit != "1" else name


def distribution_panels(rows: list[dict], controllers: list[str], keys=DISTRIBUTIONS) -> list[tuple[str, list[list[float]]]]:
    """(metric, its values per controller) of each metric to draw: the completed, not diverged runs' finite values;
    a metric without any, or zero in every run (nothing saturated, say), has no panel."""
    panels = []
    for key in keys:
        if key not in rows[0]:
            continue
        data = [[float(r[key]) for r in rows if r["controller"] == c and ok(r) and r.get(key) is not None
                 and math.isfinite(r[key])] for c in controllers]
        if any(v != 0.0 for group in data for v in group):
            panels.append((key, data))
    return panels


def panel_colours(rows: list[dict], controllers: list[str], key: str, by: str) -> list[list[float]]:
    """The value of the varied parameter `by` of each point distribution_panels gives for `key`, in the same order."""
    return [[float(r[by]) for r in rows if r["controller"] == c and ok(r) and r.get(key) is not None
             and math.isfinite(r[key])] for c in controllers]


def group_kind(values: list[float]) -> str:
    """How a group is drawn: 'strip' (each run a point) below STRIP_BELOW runs, else 'box'."""
    return "strip" if len(values) < STRIP_BELOW else "box"


def draw_distribution(ax, key: str, data: list[list[float]], labels: list[str], colours: list[list[float]] | None = None,
                      norm=None) -> list[str]:
    """One metric's panel: a box or a strip per group, plain tick labels, the unit on the axis; the kinds drawn.
    colours: each point's value of a varied parameter (panel_colours): every run is then drawn as a point over its box,
    coloured by that value (norm: the colour scale the figure's colour bar shows)."""
    from matplotlib.ticker import FuncFormatter, NullFormatter

    kinds = [group_kind(g) for g in data]
    boxes = [i for i, k in enumerate(kinds) if k == "box" and data[i]]
    if boxes:
        ax.boxplot([data[i] for i in boxes], positions=[i + 1 for i in boxes], widths=0.5, showfliers=colours is None)
    for i, g in enumerate(data):
        if not g or (kinds[i] == "box" and colours is None):
            continue
        offsets = np.linspace(-0.12, 0.12, len(g)) if len(g) > 1 else np.zeros(1)  # the points side by side
        if colours is not None:
            ax.scatter(i + 1 + offsets, g, s=10, c=colours[i], cmap="viridis", norm=norm, zorder=3, linewidths=0)
        else:
            ax.scatter(i + 1 + offsets, g, s=18, color="C0", zorder=3)
        if kinds[i] == "strip":
            ax.hlines(np.median(g), i + 0.75, i + 1.25, color="C1")  # the median as a bar
    ax.set_xticks(range(1, len(labels) + 1), [f"{c}\n({len(g)} runs)" for c, g in zip(labels, data)])
    ax.set_xlim(0.4, len(labels) + 0.6)
    values = np.array([v for g in data for v in g])
    positive = values[values > 0]
    if key.startswith("ISE") and len(positive) == len(values) and positive.max() > 20 * positive.min():
        ax.set_yscale("log")  # ISE spans decades between good and poor runs; plain numbers on its ticks all the same
        ax.yaxis.set_minor_formatter(NullFormatter())
    ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    ax.set_title(TITLES.get(key, key), fontsize=9)
    ax.set_ylabel(axis_label(key, metric_unit(key)))
    ax.grid(alpha=0.3, axis="y")
    return kinds


def ok(row: dict) -> bool:
    """A run that completed without diverging: its metrics are drawn and mapped."""
    return bool(row["completed"]) and not row["diverged"]

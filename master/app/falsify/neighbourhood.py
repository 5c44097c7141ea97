"""How wide the failure is: a grid around the best counterexample (each dimension ±`fraction` of its range about the
counterexample's value, clipped to the range, `points` values each), every point run as the search's evaluations run
(the same evaluator on the campaign's Dask dispatch, the same robustness), and what the grid shows: the share of it
that fails, and per dimension the failure region's width along the line through the counterexample (the other
dimensions at its values) and over the whole grid.

A needle the optimizer hit by luck shows a narrow region (one grid point wide); a wide region is a failure a test
engineer meets. The grid is also written as a campaign spec (`tiltload campaign`: docs/campaigns.md) when every
dimension is one a campaign can vary (an FMU parameter or faults.N.start|end|value), with the requirements beside it
as a requirement file: the same grid, with the campaign's metrics and logs.
"""

from __future__ import annotations

import itertools
import json
import math
from pathlib import Path

import numpy as np

from .spec import Dimension, Falsification

RESULTS, SUMMARY, FIGURE = "neighbourhood.parquet", "neighbourhood.txt", "neighbourhood.png"
CAMPAIGN, REQUIREMENTS = "neighbourhood_campaign.toml", "neighbourhood_requirements.yaml"


def axis(d: Dimension, centre: float, fraction: float, points: int) -> list[float | int]:
    """A dimension's grid values: `points` evenly spaced over centre ± fraction of its range, clipped to the range
    (integers rounded, repeats dropped); the centre is always one of them."""
    half = fraction * (d.high - d.low)
    low, high = max(d.low, centre - half), min(d.high, centre + half)
    values = sorted({*np.linspace(low, high, points).tolist(), float(centre)})
    if d.integer:
        values = sorted({int(round(v)) for v in values})
    return values


def grid(spec: Falsification, best: dict, fraction: float = 0.1, points: int | None = None) -> tuple[dict, list[dict]]:
    """The axes ({name: values}) and every point of their product ({name: value})."""
    points = points or (5 if len(spec.dimensions) <= 3 else 3)
    axes = {d.name: axis(d, float(best[d.name]), fraction, points) for d in spec.dimensions}
    return axes, [dict(zip(axes, combo)) for combo in itertools.product(*axes.values())]


def widths(spec: Falsification, best: dict, axes: dict, rows: list[dict]) -> dict[str, dict]:
    """Per dimension: the failing values along the line through the counterexample (their span, and the grid's span
    on that line), and the span of failing values over the whole grid."""
    out = {}
    failing = [r for r in rows if r.get("robustness") is not None and r["robustness"] < 0]
    for d in spec.dimensions:
        line = [r for r in rows if all(r[o.name] == _at(axes[o.name], best[o.name]) for o in spec.dimensions if o is not d)]
        fails = sorted(r[d.name] for r in line if r.get("robustness") is not None and r["robustness"] < 0)
        anywhere = sorted(r[d.name] for r in failing)
        out[d.name] = {"line_fails": f"{len(fails)}/{len(line)}",
                       "line_width": (fails[-1] - fails[0]) if fails else 0.0,
                       "line_span": (max(axes[d.name]) - min(axes[d.name])),
                       "grid_width": (anywhere[-1] - anywhere[0]) if anywhere else 0.0}
    return out


def _at(values: list, centre) -> float | int:
    """The axis value nearest the counterexample's (it is one of them; nearest: an integer axis rounds it)."""
    return min(values, key=lambda v: abs(v - centre))


def campaign_text(spec: Falsification, best: dict, axes: dict, requirements_file: str) -> str | None:
    """The grid as a campaign spec, or None when a dimension is not one a campaign varies (gust.*, initial.*, a
    fault's duration: what they set depends on more than one value)."""
    lines = [f'name = "{spec.name}-neighbourhood"', "[base]", f'scenario = "{spec.scenario}"',
             f"trajectory = {json.dumps(spec.trajectory_arg if not spec.trajectory_arg.isdigit() else int(spec.trajectory_arg))}",
             f'controllers = [{json.dumps(spec.controller)}]', f"stop_time = {spec.stop_time!r}",
             f"gusts = {'true' if spec.gusts else 'false'}"]
    if any(d.target.startswith(("gust.", "initial.")) or d.target.endswith(".duration") for d in spec.dimensions):
        return None
    if spec.wind_file is not None:
        lines.append(f"wind = {json.dumps(str(spec.wind_file))}")
    if spec.parameters:
        lines.append(f"parameters = {_toml(spec.parameters)}")
    if spec.faults:
        lines.append(f"faults = {_toml(spec.faults)}")
    lines += ["[vary]", f"seeds = [{spec.loop_seed}]", 'method = "grid"']
    for d in spec.dimensions:
        lines += ["[[vary.parameters]]", f'name = "{d.name}"', f'targets = ["{d.target}"]',
                  f"values = [{', '.join(repr(v) for v in axes[d.name])}]"]
    lines += ["[keep]", f'requirements = "{requirements_file}"']
    return "\n".join(lines) + "\n"


def _toml(value) -> str:
    """A value as TOML (inline tables and arrays; floats that read back exactly)."""
    if isinstance(value, dict):
        return "{" + ", ".join(f"{json.dumps(str(k))} = {_toml(v)}" for k, v in value.items()) + "}"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    return json.dumps(str(value))


def requirements_yaml(spec: Falsification) -> str:
    import yaml

    return yaml.safe_dump({"requirements": [{"name": r.name, "description": r.description or r.name, "formula": r.formula}
                                            for r in spec.requirements]}, sort_keys=False, width=1000)


def figure(spec: Falsification, best: dict, axes: dict, rows: list[dict], path: Path) -> Path:
    """Robustness along each dimension's line through the counterexample (one panel a dimension), failing points
    marked; the first two dimensions' plane through it as a map."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    dims = spec.dimensions
    fig, axs = plt.subplots(1, len(dims) + (1 if len(dims) >= 2 else 0), figsize=(3.2 * (len(dims) + 1), 3.2))
    axs = np.atleast_1d(axs)
    centre = {d.name: _at(axes[d.name], best[d.name]) for d in dims}
    for ax, d in zip(axs, dims):
        line = sorted((r for r in rows if all(r[o.name] == centre[o.name] for o in dims if o is not d)), key=lambda r: r[d.name])
        x = [r[d.name] for r in line]
        y = [r["robustness"] for r in line]
        ax.plot(x, y, "o-", color="C0")
        ax.plot([v for v, r in zip(x, y) if r < 0], [r for r in y if r < 0], "o", color="C3", label="fails")
        ax.axhline(0.0, color="k", lw=0.8, ls="--")
        ax.axvline(float(best[d.name]), color="C3", lw=0.8, ls=":")
        ax.set_xlabel(f"{d.name} ({d.target})")
        ax.set_ylabel("robustness")
        ax.grid(True, alpha=0.3)
    if len(dims) >= 2:
        a, b = dims[0], dims[1]
        plane = [r for r in rows if all(r[o.name] == centre[o.name] for o in dims[2:])]
        table = np.full((len(axes[b.name]), len(axes[a.name])), np.nan)
        for r in plane:
            table[axes[b.name].index(r[b.name]), axes[a.name].index(r[a.name])] = r["robustness"]
        ax = axs[-1]
        lim = np.nanmax(np.abs(table)) if np.isfinite(table).any() else 1.0
        im = ax.pcolormesh(axes[a.name], axes[b.name], table, cmap="RdBu", vmin=-lim, vmax=lim, shading="nearest")
        ax.contour(axes[a.name], axes[b.name], table, levels=[0.0], colors="k", linewidths=0.8)
        ax.plot([float(best[a.name])], [float(best[b.name])], "k*")
        ax.set_xlabel(a.name)
        ax.set_ylabel(b.name)
        fig.colorbar(im, ax=ax, label="robustness")
    fig.suptitle(f"{spec.name}: the grid around the counterexample")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def run(spec: Falsification, best: dict, evaluate_batch, make_case, out: Path, fraction: float = 0.1,
        points: int | None = None) -> str:
    """Run the grid around `best`, write its results, campaign spec, figure and summary; the summary's text."""
    from .search import assemble

    axes, grid_points = grid(spec, best, fraction, points)
    cases = [make_case(f"n{i:05d}", values) for i, values in enumerate(grid_points)]
    got = evaluate_batch(cases)
    rows = [got[c["run_id"]] for c in cases if c["run_id"] in got]
    sub = out / "neighbourhood"
    sub.mkdir(parents=True, exist_ok=True)
    assemble(sub, rows)
    (sub / "falsification.parquet").replace(sub / RESULTS)
    (sub / REQUIREMENTS).write_text(requirements_yaml(spec))
    campaign = campaign_text(spec, best, axes, REQUIREMENTS)
    if campaign is not None:
        (sub / CAMPAIGN).write_text(campaign)
    scored = [r for r in rows if r.get("robustness") is not None and not math.isnan(r["robustness"])]
    failing = sum(1 for r in scored if r["robustness"] < 0)
    lines = [f"neighbourhood of the counterexample: {len(rows)} grid points ({' x '.join(str(len(v)) for v in axes.values())}, "
             f"±{fraction:.0%} of each range about it, clipped), {failing} fail: {failing / max(len(scored), 1):.1%} of the grid"]
    for name, w in widths(spec, best, axes, rows).items():
        lines.append(f"  {name}: along the line through it {w['line_fails']} fail, width {w['line_width']:.4g} of "
                     f"{w['line_span']:.4g}; failing values over the grid span {w['grid_width']:.4g}")
    lines.append(f"  results {sub / RESULTS}; figure {sub / FIGURE}; " + (f"campaign spec {sub / CAMPAIGN}" if campaign else
                 "no campaign spec (a dimension a campaign cannot vary: gust.*, initial.* or a fault's duration)"))
    if len(rows) < len(cases):
        lines.append(f"  {len(cases) - len(rows)} grid points failed for their environment: not in the results")
    if rows:
        figure(spec, best, axes, rows, sub / FIGURE)
    text = "\n".join(lines)
    (sub / SUMMARY).write_text(text + "\n")
    return text

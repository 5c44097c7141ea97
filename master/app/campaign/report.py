"""`tiltload campaign report RESULTS`: distributions per controller, success and ISE maps, the worst runs.

Writes <folder>/report.md with its figures beside it: box plots of the metrics per controller;
over two varied parameters (the first two, or --x/--y), per controller, the share of runs that
completed without diverging and the mean ISE of the position; the worst runs by the maximum
tracking error, each with the `tiltload run` command that reruns it alone.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

ISE_POSITION = ("ISE(x)", "ISE(y)", "ISE(z)")


class ReportError(ValueError):
    """Results that cannot be reported; the message says why."""


def _load(results: Path) -> tuple[list[dict], list[str]]:
    import pyarrow.parquet as pq

    if not results.is_file():
        raise ReportError(f"{results} does not exist (run the campaign first: tiltload campaign SPEC)")
    try:
        rows = pq.read_table(results).to_pylist()
    except Exception as err:  # pyarrow's many error types: one line
        raise ReportError(f"{results} is not a campaign's results file: {str(err).splitlines()[0]}") from None
    if not rows or "run_id" not in rows[0] or "controller" not in rows[0]:
        raise ReportError(f"{results} has no campaign rows")
    fixed = {"run_id", "controller", "seed", "completed", "diverged", "diverged_at", "error"}
    metrics = {"max_tracking_error", "time_saturated", "zse_containment", *(k for k in rows[0] if k.startswith(("ISE(", "IADU(")))}
    judged = {k for k in rows[0] for n in [k.rsplit("_", 1)[0]]  # keep.requirements' columns, in pairs
              if {f"{n}_verdict", f"{n}_robustness"} <= set(rows[0]) and k in (f"{n}_verdict", f"{n}_robustness")}
    varied = [k for k in rows[0] if k not in fixed and k not in metrics and k not in judged]
    return rows, varied


def _ok(r: dict) -> bool:
    return bool(r["completed"]) and not r["diverged"]


def rerun_command(row: dict, spec: dict | None) -> str:
    """The `tiltload run` that repeats one run of a campaign alone (its parameters are in the spec's targets)."""
    base = (spec or {}).get("base", {})
    parts = ["tiltload run", f"--scenario {base.get('scenario', 'zse')}", f"--trajectory {base.get('trajectory', 1)}",
             f"--controller {row['controller']}", f"--seed {row['seed']}"]
    if base.get("stop_time"):
        parts.append(f"--stop-time {base['stop_time']:g}")
    if base.get("gusts") is False:
        parts.append("--no-gusts")
    for key, value in base.get("parameters", {}).items():
        parts.append(f"--set {key}={value}")
    for p in (spec or {}).get("vary", {}).get("parameters", []):
        for target in p["targets"]:
            parts.append(f"--set {target}={row[p['name']]:.10g}")
    return " ".join(parts)


def report(results: Path, spec_path: Path | None = None, x: str | None = None, y: str | None = None) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    results = Path(results)
    rows, varied = _load(results)
    spec = None
    if spec_path is None:  # the campaign keeps a copy of its spec next to the results
        spec_path = next((p for p in (results.parent / n for n in ("spec.toml", "spec.yaml", "spec.yml")) if p.is_file()), None)
    if spec_path is not None:
        from .spec import read_spec_file

        spec = read_spec_file(Path(spec_path))
    folder = results.parent
    controllers = list(dict.fromkeys(r["controller"] for r in rows))
    lines = [f"# Campaign report: {results.parent.name}", "",
             f"{len(rows)} runs; controllers {', '.join(controllers)}; varied: {', '.join(varied) or 'seeds only'}.", ""]
    lines += ["## Per controller", "", "| controller | runs | completed, not diverged | median ISE(x) | median ISE(z) | "
              "median max tracking error (m) | worst max tracking error (m) | median time saturated |", "|---|---|---|---|---|---|---|---|"]
    for c in controllers:
        rs = [r for r in rows if r["controller"] == c]
        good = [r for r in rs if _ok(r)]

        def med(key, rs=good):
            vals = [r[key] for r in rs if r.get(key) is not None and not math.isnan(r[key])]
            return f"{np.median(vals):.4g}" if vals else "—"
        worst = max((r["max_tracking_error"] for r in good if r.get("max_tracking_error") is not None), default=math.nan)
        lines.append(f"| {c} | {len(rs)} | {len(good)} ({100 * len(good) / len(rs):.0f} %) | {med('ISE(x)')} | {med('ISE(z)')} | "
                     f"{med('max_tracking_error')} | {worst:.4g} | {med('time_saturated')} |")
    figures = []
    keys = [k for k in ("ISE(x)", "ISE(y)", "ISE(z)", "max_tracking_error", "IADU(f_R)", "time_saturated") if k in rows[0]]
    fig, axes = plt.subplots(1, len(keys), figsize=(3.2 * len(keys), 3.6))
    for ax, key in zip(np.atleast_1d(axes), keys):
        data = [[r[key] for r in rows if r["controller"] == c and _ok(r) and r.get(key) is not None] for c in controllers]
        ax.boxplot(data, tick_labels=controllers)
        ax.set_title(key)
        ax.set_yscale("log" if key.startswith("ISE") else "linear")
    fig.tight_layout()
    fig.savefig(folder / "distributions.png", dpi=110)
    plt.close(fig)
    figures.append("distributions.png")
    lines += ["", "![metric distributions per controller](distributions.png)", ""]
    x = x or (varied[0] if len(varied) >= 1 else None)
    y = y or (varied[1] if len(varied) >= 2 else None)
    for name in (x, y):
        if name is not None and name not in varied:
            raise ReportError(f"--x/--y: {name} is not a varied parameter of this campaign (have: {', '.join(varied)})")
    if x and y:
        xs = sorted({r[x] for r in rows})
        ys = sorted({r[y] for r in rows})
        if len(xs) * len(ys) <= 400:  # a grid: maps
            fig, axes = plt.subplots(2, len(controllers), figsize=(4.2 * len(controllers), 7), squeeze=False)
            for j, c in enumerate(controllers):
                success = np.full((len(ys), len(xs)), np.nan)
                ise = np.full((len(ys), len(xs)), np.nan)
                for iy, vy in enumerate(ys):
                    for ix, vx in enumerate(xs):
                        cell = [r for r in rows if r["controller"] == c and r[x] == vx and r[y] == vy]
                        if cell:
                            success[iy, ix] = np.mean([_ok(r) for r in cell])
                            vals = [sum(r[k] for k in ISE_POSITION) for r in cell if _ok(r)]
                            ise[iy, ix] = np.mean(vals) if vals else np.nan
                for i, (grid, title, cmap) in enumerate(((success, "share completed, not diverged", "RdYlGn"),
                                                         (ise, "mean ISE(x)+ISE(y)+ISE(z)", "viridis"))):
                    ax = axes[i, j]
                    im = ax.imshow(grid, origin="lower", cmap=cmap, aspect="auto",
                                   **({"vmin": 0, "vmax": 1} if i == 0 else {}))
                    ax.set_xticks(range(len(xs)), [f"{v:.3g}" for v in xs])
                    ax.set_yticks(range(len(ys)), [f"{v:.3g}" for v in ys])
                    ax.set_xlabel(x)
                    ax.set_ylabel(y)
                    ax.set_title(f"{c}: {title}", fontsize=9)
                    fig.colorbar(im, ax=ax)
            fig.tight_layout()
            fig.savefig(folder / "maps.png", dpi=110)
            plt.close(fig)
            figures.append("maps.png")
            lines += [f"## Maps over {x} × {y}", "", "![success and ISE maps](maps.png)", ""]
            for c in controllers:
                lines += [f"### {c}: share of runs completed without diverging", "", "| " + y + " \\ " + x + " | " +
                          " | ".join(f"{v:.3g}" for v in xs) + " |", "|---" * (len(xs) + 1) + "|"]
                for vy in ys:
                    cells = []
                    for vx in xs:
                        cell = [r for r in rows if r["controller"] == c and r[x] == vx and r[y] == vy]
                        cells.append(f"{np.mean([_ok(r) for r in cell]):.2f}" if cell else "—")
                    lines.append(f"| {vy:.3g} | " + " | ".join(cells) + " |")
                lines.append("")
    worst = sorted(rows, key=lambda r: (_ok(r), -(r.get("max_tracking_error") or 0.0)))[:5]
    lines += ["## Worst runs", "", "Failed or diverged runs first, then the largest maximum tracking error.", ""]
    for r in worst:
        what = f"error: {r['error']}" if r["error"] else f"max tracking error {r['max_tracking_error']:.3g} m"
        values = ", ".join(f"{k} = {r[k]:.4g}" for k in varied)
        lines += [f"- {r['controller']}, seed {r['seed']}{', ' + values if values else ''}: {what}", "",
                  f"  `{rerun_command(r, spec)}`", ""]
    lines += requirement_section(rows, varied, spec)
    path = folder / "report.md"
    path.write_text("\n".join(lines) + "\n")
    return path


def requirement_section(rows: list[dict], varied: list[str], spec: dict | None) -> list[str]:
    """keep.requirements' columns: the pass rate of each requirement, and its worst runs by robustness with their
    rerun commands (none: no requirement columns)."""
    names = [k[:-len("_verdict")] for k in (rows[0] if rows else {}) if k.endswith("_verdict") and f"{k[:-8]}_robustness" in rows[0]]
    if not names:
        return []
    lines = ["## Requirements", "", "| requirement | PASS | FAIL | INCONCLUSIVE | ZERO | pass rate | least robustness |",
             "|---|---|---|---|---|---|---|"]
    for n in names:
        verdicts = [r[f"{n}_verdict"] for r in rows]
        robust = [r[f"{n}_robustness"] for r in rows if r[f"{n}_robustness"] is not None and math.isfinite(r[f"{n}_robustness"])]
        counts = {v: verdicts.count(v) for v in ("PASS", "FAIL", "INCONCLUSIVE", "ZERO")}
        lines.append(f"| {n} | {counts['PASS']} | {counts['FAIL']} | {counts['INCONCLUSIVE']} | {counts['ZERO']} | "
                     f"{100 * counts['PASS'] / len(rows):.0f} % | {min(robust, default=math.nan):.4g} |")
    lines.append("")
    for n in names:
        judged = [r for r in rows if r[f"{n}_robustness"] is not None and math.isfinite(r[f"{n}_robustness"])]
        worst = sorted(judged, key=lambda r: r[f"{n}_robustness"])[:3]
        if not worst:
            continue
        lines += [f"### {n}: the least robust runs", ""]
        for r in worst:
            values = ", ".join(f"{k} = {r[k]:.4g}" for k in varied)
            lines += [f"- {r['controller']}, seed {r['seed']}{', ' + values if values else ''}: {r[f'{n}_verdict']}, "
                      f"robustness {r[f'{n}_robustness']:.4g}", "", f"  `{rerun_command(r, spec)}`", ""]
    return lines

"""`tiltload campaign report RESULTS`: distributions per controller, success and ISE maps, the worst runs.

Writes <folder>/report.md with its figures beside it: the metrics per controller (a box per controller, or each run
as a point when a controller has fewer than STRIP_BELOW; a metric zero in every run is left out);
over two varied parameters (the first two, or --x/--y), per controller, the share of runs that
completed without diverging and the mean ISE of the position; the worst runs by the maximum
tracking error, each with the `tiltload run` command that reruns it alone.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..loop.defaults import OUR_CONTROLLERS, SCENARIO
from .figures import ISE_POSITION, axis_label, distribution_panels, draw_distribution, ok, panel_colours, parameter_unit
from .fmus_record import controller_digests, fmu_section, recorded_fmus


class ReportError(ValueError):
    """Results that cannot be reported; the message says why."""


ORIGIN = "spec.origin"  # beside the results: the path of the spec the campaign ran (its relative paths are from there)


FIXED = ("run_id", "controller", "seed", "completed", "diverged", "diverged_at", "error")


def _is_metric(key: str) -> bool:
    return key in ("max_tracking_error", "time_saturated", "zse_containment", "diverged_at") or key.startswith(("ISE(", "IADU("))


def _load(results: Path, spec: dict | None = None) -> tuple[list[dict], list[str]]:
    """(rows, the varied parameters) of a results file, every row normalized to what the report reads (rows: _rows)."""
    import pyarrow.parquet as pq

    from ...engine.user_files import UserFileError, open_binary

    try:
        f = open_binary(results)
    except UserFileError as err:
        raise ReportError(f"{err} (the results of a campaign: tiltload campaign SPEC writes them)") from None
    try:
        with f:
            rows = pq.read_table(f).to_pylist()
    except Exception as err:  # pyarrow's many error types: one line
        raise ReportError(f"{results} is not a campaign's results file: {str(err).splitlines()[0]}") from None
    if not rows or "run_id" not in rows[0] or "controller" not in rows[0]:
        raise ReportError(f"{results} has no campaign rows")
    from ..case.verdict_counts import requirement_columns

    judged = requirement_columns(rows[0])  # keep.requirements' columns
    named = [p.get("name") for p in (spec or {}).get("vary", {}).get("parameters", [])]
    if named and all(n in rows[0] for n in named):  # the spec says which columns are varied parameters
        varied = named
    else:  # a column that is neither fixed, a metric nor a requirement's (an older writer's metric is one too)
        varied = [k for k in rows[0] if k not in FIXED and not _is_metric(k) and k not in judged]
    return _rows(results, rows, varied, judged), varied


def _rows(results: Path, rows: list[dict], varied: list[str], judged: set[str]) -> list[dict]:
    """Rows as the report reads them, whichever writer wrote them: run_id and controller text (refused if missing),
    completed a flag (refused if missing), diverged False and error empty where an older writer left them out, seed
    None where absent; metrics, varied parameters and robustness numbers or None, text in them refused with its
    column and run named."""
    if "completed" not in rows[0]:
        raise ReportError(f"{results}: no column completed: not a campaign's results file")
    numeric = [k for k in rows[0] if _is_metric(k) or k in varied or k.endswith("_robustness") and k in judged]
    out = []
    for i, r in enumerate(rows):
        where = f"{results}: row {i + 1}"
        for key in ("run_id", "controller"):
            if not isinstance(r.get(key), str) or not r[key].strip():
                raise ReportError(f"{where}: no {key.replace('_', ' ')} (it holds {r.get(key)!r}): not a campaign's results "
                                  "row")
        if not isinstance(r["completed"], bool):
            raise ReportError(f"{where} ({r['run_id']}): completed holds {r['completed']!r}, not true or false")
        row = {**r, "diverged": bool(r.get("diverged")), "error": str(r.get("error") or ""),
               "seed": r.get("seed") if isinstance(r.get("seed"), int) and not isinstance(r.get("seed"), bool) else None}
        for key in numeric:
            v = r.get(key)
            if v is not None and (isinstance(v, bool) or not isinstance(v, (int, float))):
                raise ReportError(f"{where} ({r['run_id']}): column {key} holds {str(v)[:40]!r} where a number goes")
        out.append(row)
    return out


def rerun_command(row: dict, spec: dict | None, spec_folder: Path | None = None, pinned: dict[str, str] | None = None) -> str:
    """The `tiltload run` that repeats one run of a campaign alone (its parameters are in the spec's targets). A user's
    controller FMU (a row names it by its stem) is named by its path, found in the spec's base.controllers relative to
    spec_folder (the folder of the spec the campaign ran), and pinned by the digest the campaign recorded (pinned:
    fmus_record.controller_digests): a rebuild at that path is refused by the rerun, not run in its place."""
    import shlex

    base = (spec or {}).get("base", {})
    controller = row["controller"]
    for c in base.get("controllers", []):
        if c not in OUR_CONTROLLERS and Path(c).stem == controller:
            controller = str((spec_folder / c).resolve() if spec_folder is not None else Path(c))
    parts = ["tiltload run", f"--scenario {base.get('scenario', SCENARIO)}", f"--trajectory {shlex.quote(str(base.get('trajectory', 1)))}",
             f"--controller {shlex.quote(controller)}"] + ([f"--seed {row['seed']}"] if row.get("seed") is not None else [])
    if (pinned or {}).get(row["controller"]) and controller != row["controller"]:
        parts.append(f"--expect-fmu controller={pinned[row['controller']]}")
    if base.get("stop_time"):
        parts.append(f"--stop-time {base['stop_time']:g}")
    if base.get("gusts") is False:
        parts.append("--no-gusts")
    for key, value in base.get("parameters", {}).items():
        parts.append(f"--set {key}={value}")
    for p in (spec or {}).get("vary", {}).get("parameters", []):
        for target in p["targets"]:
            if row.get(p["name"]) is not None:
                parts.append(f"--set {target}={row[p['name']]:.10g}")
    return " ".join(parts)


def _spec_of(results: Path, spec_path: Path | None) -> tuple[dict | None, Path | None]:
    """(the spec, the folder its relative paths are from): the one named, else the copy the campaign keeps beside its
    results and where it came from."""
    spec, spec_folder = None, None
    if spec_path is None:
        spec_path = next((p for p in (results.parent / n for n in ("spec.toml", "spec.yaml", "spec.yml")) if p.is_file()), None)
        origin = results.parent / ORIGIN
        spec_folder = Path(origin.read_text().strip()).parent if origin.is_file() else None
    if spec_path is not None:
        from .spec import read_spec_file, validate

        spec = read_spec_file(Path(spec_path))
        validate(spec, Path(spec_path))  # checked as any spec is: its rerun commands are built from it
        spec_folder = spec_folder or Path(spec_path).parent
    return spec, spec_folder


def _title(spec: dict | None, folder: Path) -> str:
    return str((spec or {}).get("name") or folder.name)  # the spec's name (its copy beside the results), not --out's


FIGURES = ("distributions.png", "maps.png")  # report() draws them beside the results; the page shows them inline


def page(results: Path, spec_path: Path | None = None):
    """The campaign's report.html as a Report (evidence.model), from its results and the figures report() drew: what
    a notebook shows of tiltload.campaign. ReportError for results it cannot read."""
    results = Path(results)
    spec, spec_folder = _spec_of(results, spec_path)
    rows, varied = _load(results, spec)
    folder = results.parent
    return _page(folder, _title(spec, folder), rows, varied, spec, spec_folder, [f for f in FIGURES if (folder / f).is_file()])


def _page(folder: Path, title: str, rows: list[dict], varied: list[str], spec: dict | None, spec_folder: Path | None,
          figures: list[str]):
    from ..evidence.campaign_page import campaign_report
    from .spec import kept_requirements

    fmus, parameters = recorded_fmus(folder)
    pinned = controller_digests(folder)  # a user's controller FMU, by the build the campaign ran
    return campaign_report(title, rows, varied, [rerun_command(r, spec, spec_folder, pinned) for r in rows],
                           [folder / f for f in figures], fmus=fmus,
                           controller_parameters=parameters, requirements=kept_requirements(spec, spec_folder))


def report(results: Path, spec_path: Path | None = None, x: str | None = None, y: str | None = None) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..output_folder import writable_folder

    results = Path(results)
    spec, spec_folder = _spec_of(results, spec_path)
    rows, varied = _load(results, spec)
    writable_folder(results.parent, "the results' folder (report.md goes there)")
    folder = results.parent
    pinned = controller_digests(folder)  # a user's controller FMU, by the build the campaign ran
    campaign_title = _title(spec, folder)
    controllers = list(dict.fromkeys(r["controller"] for r in rows))
    lines = [f"# Campaign report: {campaign_title}", "",
             f"{len(rows)} runs; controllers {', '.join(controllers)}; varied: {', '.join(varied) or 'seeds only'}.", ""]
    lines += ["## Per controller", "", "| controller | runs | completed, not diverged | median ISE(x) | median ISE(z) | "
              "median max tracking error (m) | worst max tracking error (m) | median time saturated |", "|---|---|---|---|---|---|---|---|"]
    for c in controllers:
        rs = [r for r in rows if r["controller"] == c]
        good = [r for r in rs if ok(r)]

        def med(key, rs=good):
            vals = [r[key] for r in rs if r.get(key) is not None and not math.isnan(r[key])]
            return f"{np.median(vals):.4g}" if vals else "—"
        worst = max((r["max_tracking_error"] for r in good if r.get("max_tracking_error") is not None), default=math.nan)
        lines.append(f"| {c} | {len(rs)} | {len(good)} ({100 * len(good) / len(rs):.0f} %) | {med('ISE(x)')} | {med('ISE(z)')} | "
                     f"{med('max_tracking_error')} | {worst:.4g} | {med('time_saturated')} |")
    figures = []
    panels = distribution_panels(rows, controllers)
    if panels:
        columns = 1 if len(panels) == 1 else 2  # a page: two panels a row, as many rows as it takes
        n_rows = -(-len(panels) // columns)
        fig, axes = plt.subplots(n_rows, columns, figsize=(4.1 * columns, 2.9 * n_rows + 0.7), squeeze=False)
        by = varied[0] if varied else None  # each run's point coloured by the first varied value
        norm = None
        if by is not None:
            from matplotlib.colors import Normalize

            values = [float(r[by]) for r in rows]
            norm = Normalize(min(values), max(values) if max(values) > min(values) else min(values) + 1)
        for ax, (key, data) in zip(axes.ravel(), panels):
            draw_distribution(ax, key, data, controllers, panel_colours(rows, controllers, key, by) if by else None, norm)
        for ax in axes.ravel()[len(panels):]:
            ax.remove()
        fig.suptitle(f"Campaign {campaign_title}: the metrics of the runs completed without diverging"
                     + (f"; each run a point coloured by its {by}" if by else ""), fontsize=10)
        fig.tight_layout()
        if by is not None:
            from matplotlib.cm import ScalarMappable

            fig.colorbar(ScalarMappable(norm=norm, cmap="viridis"), ax=list(axes.ravel()[:len(panels)]), shrink=0.6,
                         label=axis_label(by, parameter_unit(by, spec)))
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
        xs = sorted({r[x] for r in rows if r.get(x) is not None})
        ys = sorted({r[y] for r in rows if r.get(y) is not None})
        if len(xs) * len(ys) <= 400:  # a grid: maps
            # a page: a row per controller, its success beside its ISE
            fig, axes = plt.subplots(len(controllers), 2, figsize=(8.4, 3.2 * len(controllers) + 0.7), squeeze=False)
            x_label, y_label = axis_label(x, parameter_unit(x, spec)), axis_label(y, parameter_unit(y, spec))
            for j, c in enumerate(controllers):
                success = np.full((len(ys), len(xs)), np.nan)
                ise = np.full((len(ys), len(xs)), np.nan)
                for iy, vy in enumerate(ys):
                    for ix, vx in enumerate(xs):
                        cell = [r for r in rows if r["controller"] == c and r[x] == vx and r[y] == vy]
                        if cell:
                            success[iy, ix] = np.mean([ok(r) for r in cell])
                            vals = [sum(r[k] for k in ISE_POSITION) for r in cell
                                    if ok(r) and all(r.get(k) is not None for k in ISE_POSITION)]
                            ise[iy, ix] = np.mean(vals) if vals else np.nan
                for i, (grid, title, cmap, unit) in enumerate(((success, "share completed, not diverged", "RdYlGn",
                                                                "share of runs"),
                                                               (ise, "mean ISE(x)+ISE(y)+ISE(z)", "viridis", "m²·s"))):
                    ax = axes[j, i]
                    ax.set_xticks(range(len(xs)), [f"{v:.3g}" for v in xs])
                    ax.set_yticks(range(len(ys)), [f"{v:.3g}" for v in ys])
                    ax.set_xlabel(x_label)
                    ax.set_ylabel(y_label)
                    ax.set_title(f"{c}: {title}", fontsize=9)
                    if np.isnan(grid).all():  # no run to average: said, not an empty square
                        ax.text(0.5, 0.5, "no run completed", transform=ax.transAxes, ha="center", va="center")
                        continue
                    im = ax.imshow(grid, origin="lower", cmap=cmap, aspect="auto",
                                   **({"vmin": 0, "vmax": 1} if i == 0 else {}))
                    fig.colorbar(im, ax=ax, label=unit)
            fig.suptitle(f"Campaign {campaign_title}: over {x} and {y}", fontsize=10)
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
                        cells.append(f"{np.mean([ok(r) for r in cell]):.2f}" if cell else "—")
                    lines.append(f"| {vy:.3g} | " + " | ".join(cells) + " |")
                lines.append("")
    worst = sorted(rows, key=lambda r: (ok(r), -(r.get("max_tracking_error") or 0.0)))[:5]
    lines += ["## Worst runs", "", "Failed or diverged runs first, then the largest maximum tracking error.", ""]
    for r in worst:
        kept = r.get("max_tracking_error")
        what = (f"error: {r['error']}" if r["error"] else f"max tracking error {kept:.3g} m" if kept is not None
                else "completed" + (", diverged" if r["diverged"] else ""))
        values = ", ".join(f"{k} = {r[k]:.4g}" for k in varied if r.get(k) is not None)
        seed = "" if r["seed"] is None else f", seed {r['seed']}"
        lines += [f"- {r['controller']}{seed}{', ' + values if values else ''}: {what}", "",
                  f"  `{rerun_command(r, spec, spec_folder, pinned)}`", ""]
    lines += requirement_section(rows, varied, spec, spec_folder, pinned)
    lines += fmu_section(recorded_fmus(folder)[0])
    path = folder / "report.md"
    path.write_text("\n".join(lines) + "\n")
    from ..evidence.page import write_report

    write_report(_page(folder, campaign_title, rows, varied, spec, spec_folder, figures), folder / "report.html",
                 standard_figures=False)
    return path


def written(path: Path) -> str:
    """The line that says what report() wrote (its report.md path): the page first, the text beside it."""
    return f"report: {path.with_name('report.html')} (and {path.name}, with its figures)"


def requirement_section(rows: list[dict], varied: list[str], spec: dict | None, spec_folder: Path | None = None,
                        pinned: dict[str, str] | None = None) -> list[str]:
    """keep.requirements' columns: each requirement's counts (case.verdict_counts, as every face prints them), and its
    worst runs by robustness with their rerun commands (none: no requirement columns)."""
    from ..case.verdict_counts import VERDICTS, requirement_counts, row_verdict

    tallies = requirement_counts(rows)
    if not tallies:
        return []
    names = [t.name for t in tallies]
    lines = ["## Requirements", "", f"| requirement | {' | '.join(VERDICTS)} | pass rate | least robustness |",
             "|---" * (len(VERDICTS) + 3) + "|"]
    for t in tallies:
        cells = [f"{t.counts[v]} ({t.vacuous} vacuous)" if v == "PASS" and t.vacuous else str(t.counts[v]) for v in VERDICTS]
        least = "—" if t.least_robustness is None else f"{t.least_robustness:.4g}"
        lines.append(f"| {t.name} | {' | '.join(cells)} | {100 * t.pass_rate:.0f} % | {least} |")
    if any(t.counts["ERROR"] for t in tallies):
        lines += ["", "ERROR: the run failed or diverged (its error and time are in the worst runs above) and judged nothing."]
    lines.append("")
    for n in names:
        judged = [r for r in rows if row_verdict(r, n)[2] is not None]
        worst = sorted(judged, key=lambda r: r[f"{n}_robustness"])[:3]
        if not worst:
            continue
        lines += [f"### {n}: the least robust runs", ""]
        for r in worst:
            values = ", ".join(f"{k} = {r[k]:.4g}" for k in varied if r.get(k) is not None)
            lines += [f"- {r['controller']}, seed {r['seed']}{', ' + values if values else ''}: {r[f'{n}_verdict']}, "
                      f"robustness {r[f'{n}_robustness']:.4g}", "", f"  `{rerun_command(r, spec, spec_folder, pinned)}`", ""]
    return lines

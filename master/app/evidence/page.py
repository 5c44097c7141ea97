"""The report as one HTML file: styles, figures (inline SVG, PNG as data: URIs) and the results as JSON inside it, no
script and nothing fetched (its Content-Security-Policy forbids it), so it opens from a CI artifact or an e-mail.

Jinja2 renders it (autoescaped); the figures are matplotlib's, static, so the page needs no plotting script."""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

import jinja2

from ..user_error import visible
from . import layout
from .model import COUNTED, NOT_EXERCISED, Report, counts, matrix, requirement_ids, verdict_of

_TEMPLATE = Path(__file__).with_name("report.html.j2")


def _number(x):
    if x is None:
        return None
    x = float(x)
    return x if math.isfinite(x) else None


def _result_json(r) -> dict:
    return {"name": r.name, "verdict": verdict_of(r), "vacuous": bool(getattr(r, "vacuous", False)),
            "robustness": _number(r.robustness), "first_violation": _number(r.first_violation),
            "values": {k: _number(v) for k, v in r.values.items()}, "source": r.source, "formula": r.formula,
            "description": r.description, "why": r.why}


def _table_json(t) -> dict:
    return {"title": t.title, "header": list(t.header), "rows": [list(r) for r in t.rows], "note": t.note}


def _figures_of(test, reqs_by_name) -> dict[str, dict]:
    """Requirement name -> {"svg": ..., "curves": [...]} for each result judged on the test's log."""
    from ...engine.log import reader as log_reader
    from ...engine.requirement.check import build_trace
    from ...engine.requirement.files import requirement
    from ..views.plot import unit
    from .figures import requirement_figure

    if test.log is None or not Path(test.log).is_file() or not test.results:
        return {}
    reqs = [reqs_by_name.get(r.name) or requirement(r.name, r.formula) for r in test.results if r.formula]
    topics = sorted({f"/{n.split('.')[0]}" for q in reqs for n in q.signals})
    columns, state = log_reader.read_columns(Path(test.log), topics)
    series = {topic.lstrip("/"): c for topic, c in columns.items()}
    final = not state.torn and "error" not in log_reader.read_metadata(Path(test.log))
    out, cache = {}, {}
    for req, result in zip(reqs, [r for r in test.results if r.formula]):
        if any(n.split(".")[0] not in series or n.split(".", 1)[1] not in series[n.split(".")[0]][1] for n in req.signals):
            continue  # INCONCLUSIVE for a signal the log lacks: nothing to draw
        trace = build_trace(series, req.signals, cache)
        svg, curves = requirement_figure(req, trace, result, _unit_of(unit), final)
        out[req.name] = {"svg": svg, "curves": [vars(c) for c in curves]}
    return out


def _unit_of(unit):
    """A signal's unit by its name: a reference (x_ref) has its state's, a number the loop does not know none."""
    def of(name: str) -> str:
        base = name.split(".", 1)[-1]
        base = base[:-4] if base.endswith("_ref") else base
        known = base in ("f_R", "f_L", "d_x", "d_y", "d_z", "tau_R", "tau_L") or base.removesuffix("_dot") in (
            "x", "y", "z", "x_B", "y_B", "z_B", "phi", "theta", "psi", "alpha_R", "alpha_L", "gamma_1", "gamma_2")
        return unit(base) if known else "1"
    return of


def render(report: Report, standard_figures: bool = True, fragment: bool = False) -> str:
    """The report's HTML: a whole page, or (fragment) the same content as one <div> with its styles scoped to it and
    without the results' JSON, for a notebook's rich display (html_fragment)."""
    from .figures import standard_figures as figures_of_log

    reqs_by_name = {r.name: r for r in report.declared}
    shown = report.tests if report.listed is None else report.tests[:report.listed]
    everything = matrix(report)
    tests = []
    for test in shown:
        figures = _figures_of(test, reqs_by_name)
        tests.append({
            "name": test.name, "command": test.command, "case": {k: str(v) for k, v in test.case.items()},
            "log": str(test.log) if test.log else "", "metrics": {k: _number(v) for k, v in test.metrics.items()},
            "error": test.error, "outcome": test.outcome, "failure": test.failure,
            "results": [_result_json(r) for r in test.results], "figures": figures,
            "standard": figures_of_log(test.log) if standard_figures and test.log and Path(test.log).is_file() else [],
            "environment": test.environment.to_json() if test.environment else None,
            "baselines": [{"what": b.what, "file": b.file, "outcome": b.outcome, "tables": [_table_json(t) for t in b.tables],
                           "figures": list(b.figures)} for b in test.baselines],
        })
    data = {"title": report.title, "kind": report.kind, "generated": time.strftime("%Y-%m-%d %H:%M:%S %Z"),
            "counts": counts(report), "total": len(report.tests),
            "matrix": {name: {t.name: row[t.name] for t in shown} for name, row in everything.items()},
            "requirements": [{"name": n, "source": s} for n, s in requirement_ids(report)],
            "environment": report.environment.to_json(), "summary": report.summary,
            "tables": [_table_json(t) for t in report.tables],
            "tests": [{k: v for k, v in t.items() if k not in ("figures", "standard", "baselines")}
                      | {"baselines": [{k: v for k, v in b.items() if k != "figures"} for b in t["baselines"]]}
                      | {"curves": {name: f["curves"] for name, f in t["figures"].items()}} for t in tests]}
    env = jinja2.Environment(autoescape=True, undefined=jinja2.StrictUndefined, trim_blocks=True, lstrip_blocks=True,
                             finalize=visible)
    env.filters["num"] = lambda x: "" if x is None else f"{x:.6g}"
    env.filters["cls"] = lambda v: v.split(" ")[0].lower() + (" vacuous" if "vacuous" in v else "") if v else ""
    page = env.from_string(_TEMPLATE.read_text(encoding="utf-8"))
    matrices, scalars = layout.parameters(data["environment"]["controller_parameters"])
    return page.render(report=data, tests=tests, fragment=fragment, counted=COUNTED, not_exercised=NOT_EXERCISED, figures=report.figures,
                       overall=layout.overall(data["counts"]), columns=layout.columns(tests, data["matrix"], report.kind),
                       tested=layout.what_was_tested(data["environment"], tests, len(report.tests), report.kind),
                       gain_matrices=matrices, scalars=scalars,
                       data_json=_script_safe(json.dumps(data, allow_nan=False, separators=(",", ":"))))


def html_fragment(report: Report, standard_figures: bool = True) -> str:
    """The report as Jupyter shows it inline (an object's _repr_html_): the page's content, no script, nothing fetched."""
    return render(report, standard_figures, fragment=True)


# JSON's own escapes for what HTML gives meaning to inside a script or data block: '<' (</script, <!--, <script: the
# script data states), '>' (-->), '&', and U+2028/2029 (line ends to JavaScript before ES2019); the JSON means the same
_SCRIPT_ESCAPES = {"<": "\\u003c", ">": "\\u003e", "&": "\\u0026", "\u2028": "\\u2028", "\u2029": "\\u2029"}


def _script_safe(text: str) -> str:
    """JSON inside <script type="application/json">: nothing in it can end or change the element (every character
    _SCRIPT_ESCAPES names written as JSON's escape of it)."""
    return "".join(_SCRIPT_ESCAPES.get(c, c) for c in text)


def write_report(report: Report, path: Path, standard_figures: bool = True, inputs=None) -> Path:
    """Write the report to path (a folder is made as needed); returns path. A path ending .pdf: the page beside it
    (.html) and its print to PDF. inputs: the command's inputs ({"the log it
    judges": log} or pairs): a path that is one of them is refused (output_folder.writable_file), the input kept."""
    from ..output_folder import writable_file, write_file

    refused = list(_inputs_of(report)) + list(inputs.items() if isinstance(inputs, dict) else inputs or ())
    path = writable_file(Path(path), "the report", refused)
    if path.suffix.lower() != ".pdf":
        return write_file(path, render(report, standard_figures))
    # a report for paper: the page beside it (same name, .html), printed by headless Chromium (paper.py)
    from .paper import print_pdf

    page = write_file(writable_file(path.with_suffix(".html"), "the report's page", refused), render(report, standard_figures))
    return print_pdf(page, path)


def _inputs_of(report: Report):
    """What every report judges: each test's log."""
    for test in report.tests:
        if test.log:
            yield "the log it judges", Path(test.log)

"""How a report reads at one glance: its first screen (what was tested, the overall verdict), the traceability
matrix's columns (short labels with a key, failing tests first, the rest summarised) and the controller's parameters
(a gain matrix K_i_j as a matrix). Plain data for the template; page.py calls it."""

from __future__ import annotations

import re

from .model import COUNTED, ERROR, FAIL, INCONCLUSIVE, NOT_EXERCISED, PASS, VACUOUS, ZERO

COLUMNS = 12  # tests the matrix shows as columns: at 1,400 px and at A4 width a column each stays legible
_WORST_FIRST = (FAIL, ERROR, INCONCLUSIVE, ZERO)


def overall(counts: dict[str, int]) -> str:
    """The report's verdict: FAIL if anything failed, else ERROR, INCONCLUSIVE, ZERO (the worst thing that happened),
    else PASS when something passed, else that nothing was judged."""
    for verdict in _WORST_FIRST:
        if counts.get(verdict):
            return verdict
    return PASS if counts.get(PASS) or counts.get(VACUOUS) else "nothing judged"


def _rank(test: dict, matrix: dict[str, dict[str, str]]) -> int:
    cells = {row[test["name"]] for row in matrix.values()} | {test.get("outcome")}
    cells |= {ERROR} if test.get("error") else set()
    return 0 if cells & {FAIL, ERROR} else 1 if cells & {INCONCLUSIVE, ZERO} else 2  # a failure and an error alike


def columns(tests: list[dict], matrix: dict[str, dict[str, str]], kind: str) -> dict:
    """The matrix's columns: {"shown": [(label, test name)], "rest": [names], "rows": {requirement: counts of the rest}}.
    Failing tests and errors first (then inconclusive, zero), else in the report's order; labelled R1.. (a campaign's
    runs) or T1.. in the order shown, so the key below the matrix reads left to right."""
    order = sorted(range(len(tests)), key=lambda i: (_rank(tests[i], matrix), i))
    prefix = "R" if kind == "campaign" else "T"
    shown = [(f"{prefix}{k + 1}", tests[i]["name"]) for k, i in enumerate(order[:COLUMNS])]
    # a campaign's run is told apart by what varied: its case (controller, seed, the varied values) in the key
    cases = {tests[i]["name"]: ", ".join(f"{k} {_short(v)}" for k, v in tests[i]["case"].items()) if kind == "campaign"
             else "" for i in order[:COLUMNS]}
    rest = [tests[i]["name"] for i in order[COLUMNS:]]
    summary = {}
    for req, row in matrix.items():
        tally = {v: sum(1 for n in rest if row[n] == v) for v in (*COUNTED, NOT_EXERCISED)}
        summary[req] = [(v, c) for v, c in tally.items() if c]
    return {"shown": shown, "rest": rest, "rows": summary, "cases": cases}


def _short(text: str) -> str:
    """A number as 6 significant digits (0.6000000000000001 reads 0.6); any other text as it is."""
    try:
        return f"{float(text):.6g}" if any(c in text for c in ".eE") else text
    except ValueError:
        return text


_GAIN = re.compile(r"^(.*?)_(\d+)_(\d+)$")


def _natural(name: str):
    return [int(p) if p.isdigit() else p for p in re.split(r"(\d+)", name)]


def parameters(params: dict[str, str]) -> tuple[list[dict], list[tuple[str, str]]]:
    """(matrices, scalars): names NAME_i_j (two or more of one NAME) as matrices {"name", "rows": [[value or ""]]},
    rows and columns in numeric order; the other parameters as (name, value) in natural order (K_2 before K_10)."""
    groups: dict[str, dict[tuple[int, int], str]] = {}
    for k, v in params.items():
        found = _GAIN.match(k)
        if found:
            groups.setdefault(found.group(1), {})[int(found.group(2)), int(found.group(3))] = v
    matrices, inside = [], set()
    for name, cells in groups.items():
        if len(cells) < 2:
            continue
        n_rows, n_cols = max(i for i, _ in cells) + 1, max(j for _, j in cells) + 1
        matrices.append({"name": name, "shape": f"{n_rows} × {n_cols}",
                         "rows": [[cells.get((i, j), "") for j in range(n_cols)] for i in range(n_rows)]})
        inside |= {f"{name}_{i}_{j}" for i, j in cells}
    scalars = sorted(((k, v) for k, v in params.items() if k not in inside), key=lambda kv: _natural(kv[0]))
    return sorted(matrices, key=lambda m: _natural(m["name"])), scalars


def what_was_tested(environment: dict, tests: list[dict], total: int, kind: str) -> list[tuple[str, str]]:
    """The first screen's lines (label, text): the controller (its FMU's model and SHA-256) and the case or case set."""
    lines = []
    controllers = [f for f in environment.get("fmus", []) if "controller" in f["instance"].lower()]
    if not controllers:  # the tests ran on different FMUs: each test's own controller
        controllers = list({f["sha256"]: f for t in tests if t.get("environment")
                            for f in t["environment"]["fmus"] if "controller" in f["instance"].lower()}.values())
    for f in controllers:
        lines.append(("controller", f"{f['model']} ({f['instance']}), SHA-256 {f['sha256']}"))
    if not controllers:
        lines.append(("controller", "no FMU record (the results carry none)"))
    if total == 1 and tests and tests[0]["case"]:
        case = tests[0]["case"]
        lines.append(("case", ", ".join(f"{k} {v}" for k, v in case.items() if v not in ("", "None", "{}", "[]"))))
    else:
        what = {"campaign": "runs", "pytest": "tests", "falsification": "cases", "comparison": "comparisons"}.get(kind, "logs")
        lines.append(("case set", f"{total} {what}"))
    return lines

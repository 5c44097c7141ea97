"""Generated bad requirements (issue 49: formulas of any size, non-finite values, sugar fields), fed to every surface
that reads one: `check` (a file, --formula, --explain), `run --requirements`, `falsify`, `campaign` and `tiltload.check`.
Each is refused in one line naming the problem (the limit), exit 2, never a traceback or Python's RecursionError.
Odd but valid formulas (x / 0, 0 / 0, a NaN signal, a chain of 2,000 ands) are judged, and --json stays RFC 8259."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
import tiltload as tl
from hypothesis import given, settings
from hypothesis import strategies as st
from support.isolated_case import api_call, command_exit_code, run_isolated
from support.synthetic_log import write_log
from tiltload.master.app.cli import main

EXCEPTION_NAME = re.compile(r"\b[A-Z][A-Za-z]*(Error|Exception|Exit|Interrupt)\b\s*:")


def bad_formulas() -> list[tuple[str, str]]:
    """(label, formula) beyond a limit or not finite: sizes and nestings of every kind, numbers past a double."""
    leaf = "plant.x > -5"
    out = []
    for n in (51, 1000, 30000):
        out += [(f"{n} parentheses", "(" * n + leaf + ")" * n), (f"{n} nots", "not " * n + leaf),
                (f"{n} alwayses", "always[0:0.1] " * n + leaf), (f"{n} minuses", "-" * n + "plant.x > 0"),
                (f"{n} abs", "abs(" * n + "plant.x" + ")" * n + " > 0"), (f"{n} ! and parentheses", "!(" * n + leaf + ")" * n),
                (f"{n} eventually-G", "F G " * n + leaf)]
    out += [("70,000 characters", "plant.x > 0 and " * 4375 + leaf), ("1 MB", leaf.replace(">", ">" + " " * 1_000_000)),
            ("3,000 ands (12,000 nodes)", " and ".join(["plant.x>0"] * 3000)),
            ("2,000 pluses and ands (12,000 nodes)", " and ".join(["plant.x+plant.x>0"] * 2000))]
    for number in ("1e999", "-1e999", "1e400", "2e308", "1" + "0" * 400):
        out += [(f"constant {number[:8]}", f"always plant.x < {number}"),
                (f"interval end {number[:8]}", f"always[0:{number.lstrip('-')}] plant.x > -5"),
                (f"interval start {number[:8]}", f"eventually[{number.lstrip('-')}:inf] plant.x > -5")]
    out += [("horizon 1e308", "always[0:1e308] plant.x > -5"), ("horizon 1e308 nested", "always[0:1e300] eventually[0:1e308] "
            "plant.x > -5"), ("until 1e308", "plant.x > -5 until[0:1e308] plant.z < 0")]
    return out


def bad_sugar() -> list[tuple[str, str, str]]:
    """(label, YAML entry, the field the line must name): a sugar field that is not what it says."""
    signals = ["plant.x) or (plant.z", "plant.x > 0", "x", "plant.x and plant.z", "always", "plant.x)", "(plant.x",
               "plant.x; rm -rf", "", "plant.", ".x", "plant.x + 1"]
    out = [(f"bounds.signal {s!r}", f'{{name: a, bounds: {{signal: {json.dumps(s)}, max: 1}}}}', "bounds.signal") for s in signals]
    out += [("bounds.signal a list", "{name: a, bounds: {signal: [plant.x], max: 1}}", "bounds.signal"),
            ("bounds.signal a number", "{name: a, bounds: {signal: 1, max: 1}}", "bounds.signal")]
    formulas = ["plant.x > 0)", "(plant.x > 0", "plant.x > 0) or (plant.z > 1", "plant.x", "", "plant.x > 0 and",
                "(" * 60 + "plant.x > 0" + ")" * 60, "plant.x > 1e999", "plant.x > 0) implies (plant.z < 0"]
    for key in ("trigger", "response"):
        for f in formulas:
            other = "response" if key == "trigger" else "trigger"
            out.append((f"response.{key} {f[:30]!r}", f'{{name: a, response: {{{key}: {json.dumps(f)}, {other}: "plant.x > 0", '
                                                      f'within: 1}}}}', f"response.{key}"))
    return out


@pytest.fixture(scope="module")
def log(tmp_path_factory):
    t = np.arange(201) * 0.01  # 2 s
    return write_log(tmp_path_factory.mktemp("logs") / "run.mcap", {"plant": (t, {"x": np.sin(t), "z": -2 + 0 * t})},
                     stop_time=2.0)


def _one_line_exit_2(argv, capsys) -> str | None:
    """None if the command refused its input in one line with exit 2, else what went wrong."""
    code = command_exit_code(argv)  # its own session and TMPDIR: what it leaves behind is one more line
    out, err = capsys.readouterr()
    lines = [ln for ln in err.splitlines() if ln.strip()]
    if code != 2:
        return f"exit {code}: {(lines or out.splitlines())[-1:]}"
    if len(lines) != 1:
        return f"{len(lines)} lines on stderr"
    if "Traceback" in err or EXCEPTION_NAME.search(lines[0]) or "a bug" in lines[0] or "recursion" in lines[0]:
        return lines[0][:200]
    return None


def check_cases(folder, log) -> list[tuple[str, list[str], str]]:
    """(label, argv, what the line must say)."""
    cases = []
    for i, (label, formula) in enumerate(bad_formulas()):
        path = folder / f"f{i}.yaml"
        path.write_text(f"requirements:\n  - name: a\n    formula: {json.dumps(formula)}\n")
        needle = "ahead" if "horizon" in label or "until 1e308" in label else ""
        cases += [(f"check file: {label}", ["check", str(path), str(log)], needle),
                  (f"check --formula: {label}", ["check", str(log), "--formula", f"a: {formula}"], needle),
                  (f"check --explain: {label}", ["check", str(path), "--explain"], needle) if not needle else None]
    for i, (label, entry, field) in enumerate(bad_sugar()):
        path = folder / f"s{i}.yaml"
        path.write_text(f"requirements:\n  - {entry}\n")
        cases += [(f"check sugar: {label}", ["check", str(path), str(log)], field),
                  (f"check --explain sugar: {label}", ["check", str(path), "--explain"], field)]
    return [c for c in cases if c is not None]


def test_bad_requirements_for_check_and_the_api_each_get_one_line_and_exit_2(log, tmp_path, capsys):
    cases = check_cases(tmp_path, log)
    assert len(cases) >= 180, len(cases)
    problems = []
    for label, argv, needle in cases:
        why = _one_line_exit_2(argv, capsys)
        if why is None and needle:
            command_exit_code(argv)
            if needle not in capsys.readouterr().err:
                why = f"does not name {needle}"
        if why:
            problems.append(f"{label}: {why}")
    for label, formula in bad_formulas():  # the API: TiltloadError with the CLI's line, in the same isolation
        outcome = run_isolated(lambda f=formula: api_call(lambda: tl.check(log, formulas=[f"a: {f}"])))
        lines = [ln for ln in outcome.err.splitlines() if ln.strip()]
        if outcome.code != 2 or len(lines) != 1 or outcome.left_behind:
            problems.append(f"tl.check {label}: exit {outcome.code}: {lines[-1:]} {outcome.left_behind}")
    assert not problems, f"{len(problems)} of {len(cases) + len(bad_formulas())} cases:\n" + "\n".join(problems)


FALSIFY = """
name = "t"
optimizer = "uniform"
[base]
scenario = "fsi"
trajectory = 1
stop_time = 2.0
gusts = false
[[requirements]]
name = "r"
formula = {formula}
[[search]]
name = "amp"
target = "gust.amplitude"
range = [0.0, 1.0]
[gust]
start = 0.5
duration = 0.5
[budget]
simulations = 1
"""

CAMPAIGN = """
name = "c"
[base]
scenario = "fsi"
trajectory = 1
controllers = ["mixed"]
stop_time = 1.0
[vary]
seeds = [1]
[keep]
requirements = "reqs.yaml"
"""


@pytest.mark.slow
def test_bad_requirements_for_run_falsify_and_campaign_each_get_one_line_and_exit_2(fmus, tmp_path, capsys):
    """The same classes through the surfaces that run a loop: refused before anything runs."""
    picked = [c for c in bad_formulas() if c[0].startswith(("51 ", "30000 parentheses", "70,000", "3,000 ands", "constant 1e999",
                                                           "interval end 1e999", "horizon 1e308", "until"))]
    sugar = [c for c in bad_sugar() if c[0].startswith(("bounds.signal 'plant.x) or", "response.trigger 'plant.x > 0) or"))]
    cases = []
    for i, (label, formula) in enumerate(picked):
        reqs = tmp_path / f"r{i}.yaml"
        reqs.write_text(f"requirements:\n  - name: a\n    formula: {json.dumps(formula)}\n")
        cases.append((f"run --requirements: {label}", ["run", "--scenario", "fsi", "--stop-time", "2", "--fmus", str(fmus),
                                                       "--out", str(tmp_path / "runs"), "--quiet", "--no-plots", "--no-log",
                                                       "--requirements", str(reqs)]))
        spec = tmp_path / f"f{i}.toml"
        spec.write_text(FALSIFY.replace("{formula}", json.dumps(formula)))
        cases.append((f"falsify: {label}", ["falsify", str(spec), "--out", str(tmp_path / f"fo{i}"), "--fmus", str(fmus),
                                            "--workers", "1"]))
    for i, (label, entry, _) in enumerate(sugar + [(label, f"{{name: a, formula: {json.dumps(f)}}}", "")
                                                   for label, f in picked if "1e308" not in label]):
        folder = tmp_path / f"c{i}"
        folder.mkdir()
        (folder / "reqs.yaml").write_text(f"requirements:\n  - {entry}\n")
        (folder / "c.toml").write_text(CAMPAIGN)
        cases.append((f"campaign keep.requirements: {label}", ["campaign", str(folder / "c.toml"), "--fmus", str(fmus),
                                                                "--out", str(folder / "out"), "--workers", "1"]))
    problems = [f"{label}: {why}" for label, argv in cases if (why := _one_line_exit_2(argv, capsys))]
    assert not problems, f"{len(problems)} of {len(cases)} cases:\n" + "\n".join(problems)


# --- odd but valid: judged, and the JSON is RFC 8259 -------------------------------------------------------------------

def _strict_json(text: str):
    def refuse(token):
        raise AssertionError(f"{token} in the JSON: not RFC 8259")
    return json.loads(text, parse_constant=refuse)


def test_non_finite_values_get_a_defined_verdict_and_valid_json(tmp_path, capsys):
    t = np.arange(201) * 0.01
    x = np.where(t < 1.0, 1.0, np.nan)  # a signal that turns NaN at 1 s (a diverged plant)
    log = write_log(tmp_path / "nan.mcap", {"plant": (t, {"x": x, "z": -2 + 0 * t})}, stop_time=2.0)
    formulas = {"div": "always plant.x / 0 > 1", "nan0": "always[0:0.5] 0 / 0 < plant.x", "early": "always[0:0.5] plant.x > 0",
                "open": "always plant.x > 0", "failed": "always plant.x > 5", "held": "eventually plant.x > 0.5",
                "chain": " and ".join(["plant.z < 0"] * 2000)}
    argv = ["check", "--json", str(log)] + [a for n, f in formulas.items() for a in ("--formula", f"{n}: {f}")]
    code = main(argv)
    results = {r["name"]: r for r in _strict_json(capsys.readouterr().out)["logs"][0]["results"]}
    got = {n: (r["verdict"], r["robustness"]) for n, r in results.items()}
    assert got == {"div": ("INCONCLUSIVE", None), "nan0": ("INCONCLUSIVE", None), "early": ("PASS", 1.0),
                   "open": ("INCONCLUSIVE", None), "failed": ("FAIL", None), "held": ("PASS", 0.5), "chain": ("PASS", 2.0)}
    assert results["div"]["bounds"] == ["-inf", "inf"] and "plant.x is NaN from t = 1 s" in results["open"]["why"]
    assert code == 1  # the FAIL
    assert main(["check", str(log), "--formula", "open: always plant.x > 0"]) == 3  # never a NaN PASS, never ZERO
    assert "INCONCLUSIVE" in capsys.readouterr().out


def test_vacuous_pass_in_the_table_json_and_the_api(tmp_path, capsys):
    t = np.arange(201) * 0.01
    log = write_log(tmp_path / "v.mcap", {"plant": (t, {"x": np.sin(t), "z": -2 + 0 * t})}, stop_time=2.0)
    reqs = tmp_path / "r.yaml"
    reqs.write_text("requirements:\n"
                    "  - {name: gust, response: {trigger: \"plant.x > 2\", response: \"plant.z < 0\", within: 0.5}}\n"
                    "  - {name: used, response: {trigger: \"plant.x > 0.5\", response: \"plant.z < 0\", within: 0.5}}\n")
    assert main(["check", str(reqs), str(log)]) == 0  # a vacuous pass is a pass
    table = capsys.readouterr().out
    assert re.search(r"gust\s+PASS \(vacuous\)", table) and re.search(r"used\s+PASS\s", table)
    assert main(["check", "--json", str(reqs), str(log)]) == 0
    results = _strict_json(capsys.readouterr().out)["logs"][0]["results"]
    assert [(r["name"], r["vacuous"]) for r in results] == [("gust", True), ("used", False)]
    api = {r.name: r for r in tl.check(log, reqs)}
    assert api["gust"].vacuous and api["gust"].shown == "PASS (vacuous)" and not api["used"].vacuous


def test_sugar_times_keep_every_digit_and_a_checked_field_is_spliced_as_given():
    from tiltload.master.engine.requirement.files import parse_entries

    (r,) = parse_entries({"requirements": [{"name": "a", "bounds": {"signal": "plant.x", "max": 1, "from": 0.1, "to": 12.3456789}}]}, "")
    assert r.formula.a == 0.1 and r.formula.b == 12.3456789  # not 12.3457, as :g wrote it
    (g,) = parse_entries({"requirements": [{"name": "g", "response": {"trigger": "plant.x > 0 or plant.z > 1",
                                                                       "response": "plant.z < 0", "within": 0.25}}]}, "")
    assert g.text == "always ((plant.x > 0 or plant.z > 1) implies eventually[0:0.25] (plant.z < 0))"


_PIECES = ["plant.x > 0", "plant.z < 1", "(", ")", " and ", " or ", " -> ", "not ", "always[0:1] ", "eventually ", " until ",
           "plant.x", " + ", "1e999", "abs(", "[0:1]", ":", "!", "plant.x)", "(plant.z"]


@settings(max_examples=150, deadline=None)
@given(trigger=st.lists(st.sampled_from(_PIECES), min_size=1, max_size=12).map("".join),
       response=st.lists(st.sampled_from(_PIECES), min_size=1, max_size=12).map("".join),
       signal=st.lists(st.sampled_from(["plant", ".", "x", " ", ")", "(", "or", "_1", ">"]), min_size=1, max_size=6).map("".join))
def test_a_sugar_field_is_refused_naming_it_or_is_exactly_its_own_formula(trigger, response, signal):
    """Whatever the text: refused with one line naming the field, or the expansion holds the field's own tree where the
    field goes (never a text spliced in that changes the meaning around it)."""
    from tiltload.master.engine.requirement.files import RequirementError, parse_entries
    from tiltload.master.engine.requirement.stl import parse
    from tiltload.master.engine.requirement.stl import syntax as S

    entry = {"name": "r", "response": {"trigger": trigger, "response": response, "within": 1}}
    try:
        (r,) = parse_entries({"requirements": [entry]}, "")
    except RequirementError as err:
        assert "\n" not in str(err) and ("response.trigger" in str(err) or "response.response" in str(err)), str(err)
    else:
        implies = r.formula.arg
        assert isinstance(r.formula, S.Always) and isinstance(implies, S.Implies)
        assert implies.left == parse(trigger) and implies.right.arg == parse(response)
    try:
        (b,) = parse_entries({"requirements": [{"name": "b", "bounds": {"signal": signal, "min": 0}}]}, "")
    except RequirementError as err:
        assert "bounds.signal" in str(err) and "\n" not in str(err)
    else:
        assert b.formula.arg == S.Compare(">=", S.Signal(signal), S.Const(0.0))

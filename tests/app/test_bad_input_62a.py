"""Issue 62, part A: every generated case of bad_input_62a.py (malformed baselines, API writers onto bad places or their
own inputs, b2b's case lists and sides, read-only places, reports onto their inputs) one line and exit 2, nothing left
behind; a report pointed at each of its command's inputs leaves the input's bytes as they were, for every report kind;
the report's embedded JSON and its text safe from what HTML and bidirectional text give meaning to."""

from __future__ import annotations

import hashlib
import json
import re
import subprocess
import sys
from pathlib import Path

import bad_input_62a as gen
import numpy as np
import pytest
from support.isolated_case import case_problems, command_exit_code


def _digest(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


@pytest.fixture
def readonly(tmp_path):
    where = tmp_path / "ro"
    mounted = gen.readonly_mount(where)
    yield mounted
    if mounted is not None:
        subprocess.run(["umount", str(where)], capture_output=True)


def test_malformed_baselines_and_writers_are_one_line_each(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    log = gen.log_with_metrics(tmp_path / "run.mcap")
    cases = gen.baseline_cases(tmp_path / "baselines", log) + gen.writer_cases(tmp_path / "writers", log)
    assert len(cases) >= 150, len(cases)
    problems = case_problems(cases, capsys)
    assert not problems, f"{len(problems)} of {len(cases)} cases:\n" + "\n".join(problems)
    # every writer's log is still the log it was (none was written over)
    logs = sorted((tmp_path / "writers").glob("*/a.mcap"))
    assert len(logs) >= 17 and all(p.read_bytes()[:8] == b"\x89MCAP0\r\n" for p in logs)


def test_b2b_case_lists_sides_and_read_only_places_are_one_line_each(fmus, tmp_path, capsys, monkeypatch, readonly):
    monkeypatch.chdir(tmp_path)
    cases = gen.b2b_cases(tmp_path / "b2b", fmus)
    if readonly is not None:
        cases += gen.readonly_cases(tmp_path / "readonly", fmus, readonly)
    problems = case_problems(cases, capsys)
    assert not problems, f"{len(problems)} of {len(cases)} cases:\n" + "\n".join(problems)
    assert not (tmp_path / "b2b" / "out").exists(), "a side ran (or its folder was made) for a case refused before any run"


def test_a_side_that_does_not_start_says_its_own_error(fmus, tmp_path, monkeypatch):
    """Before: "log ..._candidate.mcap: no such file". A side whose FMUs fail as they start (here its controller's
    instantiation, monkeypatched) is refused with the side's own line."""
    import tiltload as tl
    from tiltload.master.engine import lifecycle

    real = lifecycle.run_plan

    def failing(plan, pool=None):
        if "candidate" in str(plan.log):
            return lifecycle.RunResult({}, None, 0, 0.0, 0.0, "controller: ImportError: No module named 'mylib'", None, None, 0.0)
        return real(plan, pool)

    monkeypatch.setattr(lifecycle, "run_plan", failing)
    with pytest.raises(tl.TiltloadError, match=r"the candidate did not start: controller: ImportError: No module named 'mylib'$"):
        tl.b2b([{"scenario": "fsi", "trajectory": 1, "stop_time": 0.2}], reference={"fmus": fmus}, candidate={"fmus": fmus},
               out=tmp_path / "out")


def test_a_candidate_controller_whose_import_fails_says_the_fmus_own_line(fmus, tmp_path, capsys):
    """A wrapped class whose module raises on import once run (here: once a flag file exists) ends b2b in the side's
    own line, as `run` says it, not "log ..._candidate.mcap: no such file"."""
    flag = tmp_path / "flag"
    source = tmp_path / "ctrl.py"
    source.write_text(f"import os\nif os.path.exists({str(flag)!r}):\n    raise ImportError('No module named mylib')\n\n"
                      + gen.CONTROLLER)
    assert command_exit_code(["wrap", str(source), "--out", str(tmp_path / "c.fmu")]) == 0
    capsys.readouterr()
    flag.touch()
    cases = tmp_path / "one.toml"
    cases.write_text('cases = [{scenario = "fsi", trajectory = 1, stop_time = 0.2}]\n')
    code = command_exit_code(["b2b", "--cases", str(cases), "--reference-fmus", str(fmus), "--candidate-fmus", str(fmus),
                              "--candidate-controller", str(tmp_path / "c.fmu"), "--out", str(tmp_path / "out")])
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
    assert code == 2 and len(err) == 1, err
    assert "the candidate did not start: controller:" in err[0] and "no such file" not in err[0], err


# ---- a report pointed at one of its command's inputs: refused, the input unchanged, per report kind -------------------

def _refused_unchanged(argv: list[str], inputs: list[Path], capsys) -> None:
    before = {p: _digest(p) for p in inputs}
    code = command_exit_code(argv)
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
    assert code == 2 and len(err) == 1 and "written over" in err[0], (code, err)
    assert {p: _digest(p) for p in inputs} == before


def test_check_report_onto_the_log_or_the_requirement_file_is_refused(tmp_path, capsys):
    log = gen.log_with_metrics(tmp_path / "a.mcap")
    reqs = tmp_path / "r.yaml"
    reqs.write_text(gen.REQS)
    for target in (log, reqs):
        _refused_unchanged(["check", str(reqs), str(log), "--report", str(target)], [log, reqs], capsys)


def test_run_report_onto_its_requirement_file_or_its_log_is_refused(fmus, tmp_path, capsys):
    reqs = tmp_path / "r.yaml"
    reqs.write_text(gen.REQS)
    run = ["run", "--scenario", "fsi", "--stop-time", "0.2", "--fmus", str(fmus), "--out", str(tmp_path / "runs"), "--quiet",
           "--no-plots", "--requirements", str(reqs), "--name", "own"]
    _refused_unchanged([*run, "--report", str(reqs)], [reqs], capsys)
    assert command_exit_code(run) == 0  # the log exists now: a report onto it is refused and the log kept
    log = tmp_path / "runs" / "own.mcap"
    _refused_unchanged([*run, "--report", str(log)], [reqs, log], capsys)


@pytest.mark.parametrize("command", ["campaign", "falsify"])
def test_campaign_and_falsification_reports_onto_their_spec_are_refused(fmus, tmp_path, capsys, command):
    """Their report.html goes into --out: a report.html there that is the spec (a link to it) is refused before the
    spec is read, and the spec is left as it was."""
    from tiltload.master.app.evidence.falsification_page import write_falsification_report
    from tiltload.master.app.user_error import UserError

    spec = tmp_path / f"{command}.toml"
    spec.write_text("# a spec\n")
    out = tmp_path / "out"
    out.mkdir()
    (out / "report.html").symlink_to(spec)
    _refused_unchanged([command, str(spec), "--out", str(out), "--fmus", str(fmus), "--workers", "1"], [spec], capsys)
    if command == "falsify":  # the page's writer itself: a report.html that is a log it judges is refused too
        log = gen.log_with_metrics(tmp_path / "best.mcap")
        (out / "report.html").unlink()
        (out / "report.html").hardlink_to(log)
        with pytest.raises(UserError, match="is the log it judges"):
            write_falsification_report("f", "", [], [], [], None, None, log, [], out)
        assert log.read_bytes()[:8] == b"\x89MCAP0\r\n"


def test_the_pytest_report_onto_a_test_file_of_the_session_is_refused(tmp_path):
    test = tmp_path / "test_user.py"
    test.write_text("def test_one():\n    assert True\n")
    before = _digest(test)
    for target in (test, tmp_path / "pytest.ini"):
        if target.name == "pytest.ini":
            target.write_text("[pytest]\n")
        kept = _digest(target)
        proc = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(test), f"--tiltload-report={target}"],
                              cwd=tmp_path, capture_output=True, text=True, timeout=300)
        assert proc.returncode == 4, proc.stdout + proc.stderr  # pytest's usage error
        assert "written over" in proc.stderr and "Traceback" not in proc.stderr, proc.stderr
        assert _digest(target) == kept
    assert _digest(test) == before


# ---- the page: its embedded JSON and its text ----------------------------------------------------------------------

BIDI = ["\u202a", "\u202b", "\u202c", "\u202d", "\u202e", "\u2066", "\u2067", "\u2068", "\u2069", "\u200e", "\u200f", "\u061c"]
HOSTILE = "</script><script>alert(1)</script><!-- x --> <SCRIPT> & \u2028\u2029 </Script "


def _page(tmp_path: Path, description: str, name: str = "low") -> str:
    from support.synthetic_log import write_log
    from tiltload.master.app.evidence import Report, test_of_log, write_report
    from tiltload.master.app.evidence.model import this_environment
    from tiltload.master.engine.requirement.check import check_log
    from tiltload.master.engine.requirement.files import load

    t = np.arange(201) * 0.01
    log = write_log(tmp_path / "a.mcap", {"plant": (t, {"x": np.sin(t), "z": -2 + 0 * t})}, stop_time=2.0)
    reqs = tmp_path / "r.yaml"
    reqs.write_text(json.dumps({"requirements": [{"name": name, "formula": "plant.z < 5", "description": description}]}))
    declared = load(reqs)
    test = test_of_log(log, check_log(log, declared), reqs)
    return write_report(Report(f"Run {description}", "check", [test], this_environment(), declared=declared),
                        tmp_path / "r.html").read_text(encoding="utf-8")


def test_the_embedded_json_holds_nothing_html_reads_inside_a_data_block(tmp_path):
    page = _page(tmp_path, HOSTILE)
    block = re.search(r'<script type="application/json" id="tiltload-results">(.*?)</script>', page, re.S)
    assert block is not None
    inside = block.group(1)
    for sequence in ("<!--", "</script", "<script", "</SCRIPT", "-->", "\u2028", "\u2029"):
        assert sequence.lower() not in inside.lower(), sequence
    assert "<" not in inside and ">" not in inside  # no tag can start or end in it
    data = json.loads(inside)  # the same JSON: what the user wrote, back unchanged
    assert HOSTILE in json.dumps(data, ensure_ascii=False) or any(HOSTILE in str(v) for v in _strings(data))
    assert page.count("</script>") == 1  # the page's one data block ends once: nothing of the user's closed it


def _strings(value):
    if isinstance(value, str):
        yield value
    elif isinstance(value, dict):
        for v in value.values():
            yield from _strings(v)
    elif isinstance(value, list):
        for v in value:
            yield from _strings(v)


def test_bidirectional_controls_in_user_text_are_shown_escaped(tmp_path):
    text = "ok" + "".join(BIDI) + "end"
    page = _page(tmp_path, text)
    for c in BIDI:
        assert c not in page, f"U+{ord(c):04X} reached the page raw"
        assert f"\\u{ord(c):04x}" in page


def test_the_pytest_plugins_failure_messages_show_bidirectional_controls_escaped():
    from tiltload.master.app.testing.report import limits_report

    name = "ISE\u202e)x(" + "\u2066"
    text = limits_report({name: 2.0}, {name: 1.0}, {"scenario": "fsi\u202e"}, "tiltload run")
    assert text is not None and not any(c in text for c in BIDI)
    assert "ISE\\u202e)x(\\u2066" in text

"""The HTML report (master/app/evidence): the decimation keeps every column's extremes (against a brute-force scan)
and a one-sample spike reaches the page; the summary counts and the traceability matrix follow from verdicts computed
here from the signals themselves; the page opens in headless Chromium with no console error, and the counts it renders
equal its JSON."""

from __future__ import annotations

import html.parser
import json
import re
import shlex
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from support.synthetic_log import write_log
from tiltload.master.app.cli import main
from tiltload.master.app.evidence import envelope

TICK = 0.01
ROOT = Path(__file__).resolve().parents[2]


def _page_data(path) -> dict:
    text = path.read_text(encoding="utf-8")
    found = re.search(r'<script type="application/json" id="tiltload-results">(.*?)</script>', text, re.S)
    return json.loads(found.group(1).replace("<\\/", "</"))


@pytest.mark.parametrize("n,columns,seed", [(10_000, 100, 0), (5_003, 37, 1), (401, 100, 2), (100_000, 800, 3)])
def test_envelope_keeps_each_columns_first_last_least_and_greatest(n, columns, seed):
    rng = np.random.default_rng(seed)
    times = np.sort(rng.uniform(0, 40, n))
    values = np.cumsum(rng.normal(size=n))
    values[rng.integers(0, n, 5)] = np.nan
    keep = envelope(times, values, columns)
    assert len(keep) <= max(n, 4 * columns + columns)  # at most 4 a column, plus one non-finite sample per column
    assert np.all(np.diff(keep) > 0)
    if n <= 4 * columns:
        assert len(keep) == n
        return
    kept = set(keep.tolist())
    width = (times[-1] - times[0]) / columns
    for j in range(columns):  # brute force: the samples of each column by a scan of the times
        members = [i for i in range(n)
                   if j * width <= times[i] - times[0] < (j + 1) * width or (j == columns - 1 and times[i] == times[-1])]
        if not members:
            continue
        assert members[0] in kept and members[-1] in kept
        finite = [i for i in members if np.isfinite(values[i])]
        if finite:
            least, greatest = min(values[i] for i in finite), max(values[i] for i in finite)
            assert any(values[i] == least for i in kept if i in members)
            assert any(values[i] == greatest for i in kept if i in members)


def _logs(tmp_path):
    """Two runs of known signals: in the first x stays within 1, in the second it leaves at t = 6 s (x = 1.5 from
    sample 600 on) and has a one-sample spike of 50 at sample 6789 of 10,000."""
    t = np.arange(10_000) * TICK
    calm = 0.5 * np.sin(t)
    rough = 0.5 * np.sin(t)
    rough[600:650] = 1.5
    rough[6789] = 50.0
    ref = np.zeros_like(t)
    logs = []
    for name, plant in (("calm", {"x": calm, "alpha_R": 0.1 + 0 * t}), ("rough", {"x": rough})):
        logs.append(write_log(tmp_path / f"{name}.mcap", {"plant": (t, plant), "scenario": (t, {"x_ref": ref})},
                              stop_time=float(t[-1])))
    reqs = tmp_path / "reqs.yaml"
    reqs.write_text(
        "requirements:\n"
        "  - name: within\n    formula: always abs(plant.x - scenario.x_ref) <= 1.0\n    source: test, the bound 1\n"
        "  - name: below_100\n    formula: always plant.x <= 100\n    source: test, the spike's ceiling\n"
        "  - name: alpha_small\n    formula: always abs(plant.alpha_R) <= 1\n    source: a signal the second log lacks\n")
    return reqs, logs, t, rough


@pytest.fixture(scope="module")
def check_report(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("report")
    reqs, logs, t, rough = _logs(tmp)
    page = tmp / "check.html"
    code = main(["check", str(reqs), *map(str, logs), "--report", str(page)])
    return code, page, t, rough


def test_verdicts_counts_and_matrix_follow_from_the_signals(check_report):
    code, page, t, rough = check_report
    assert code == 1  # a FAIL
    data = _page_data(page)
    # from the signals: calm passes both, rough leaves the 1.0 band (the 1.5 plateau and the spike) but stays below 100;
    # alpha_R (0.1) is in the first log only: INCONCLUSIVE in the second
    assert data["matrix"]["within"] == {"calm": "PASS", "rough": "FAIL"}
    assert data["matrix"]["below_100"] == {"calm": "PASS", "rough": "PASS"}
    assert data["matrix"]["alpha_small"] == {"calm": "PASS", "rough": "INCONCLUSIVE"}
    assert data["counts"] == {"PASS": 4, "FAIL": 1, "INCONCLUSIVE": 1, "PASS (vacuous)": 0, "ZERO": 0, "ERROR": 0}
    rough_results = {r["name"]: r for r in next(x for x in data["tests"] if x["name"] == "rough")["results"]}
    assert rough_results["within"]["first_violation"] == pytest.approx(t[600])
    assert rough_results["within"]["robustness"] == pytest.approx(1.0 - 50.0)
    assert rough_results["below_100"]["robustness"] == pytest.approx(100 - 50.0)


def test_not_exercised_and_error_cells():
    from tiltload.master.app.evidence import Report, Test
    from tiltload.master.app.evidence.model import counts, matrix, this_environment
    from tiltload.master.engine.requirement.check import Result
    from tiltload.master.engine.requirement.files import requirement

    declared = [requirement("a", "always plant.x <= 1"), requirement("b", "always plant.x >= -1")]
    judged = Test("judged", results=[Result("a", "PASS", 0.5, None)])
    failed = Test("failed", error="the plant diverged (at t = 3.000 s)")
    report = Report("t", "check", [judged, failed], this_environment(), declared)
    assert matrix(report) == {"a": {"judged": "PASS", "failed": "ERROR"}, "b": {"judged": "not exercised", "failed": "ERROR"}}
    assert counts(report)["ERROR"] == 1 and counts(report)["PASS"] == 1  # a test whose run failed counts once


def test_a_one_sample_spike_reaches_the_page(check_report):
    _, page, t, rough = check_report
    data = _page_data(page)
    curve = next(c for c in data["tests"][1]["curves"]["below_100"] if c["label"] == "plant.x")
    assert len(curve["times"]) < len(t) / 2  # decimated ...
    assert 50.0 in curve["values"]  # ... and the spike is there, at its time
    assert curve["times"][curve["values"].index(50.0)] == pytest.approx(t[6789])
    stride = len(t) // (len(curve["times"]) // 1)  # the naive decimation to as many points loses it
    assert 50.0 not in rough[::max(stride, 2)].tolist()


def test_the_page_is_self_contained(check_report):
    _, page, *_ = check_report
    text = page.read_text(encoding="utf-8")
    assert not re.search(r'(src|href)="(?!data:|#)', text)  # nothing fetched: figures inline, links within the page
    assert "http-equiv=\"Content-Security-Policy\"" in text and "default-src 'none'" in text


class _Cells(html.parser.HTMLParser):
    def __init__(self):
        super().__init__()
        self.summary, self.cells = {}, []
        self._count = None

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "div" and "data-verdict" in a:
            self._count = a["data-verdict"]
        if tag == "td" and "data-cell" in a:
            self.cells.append(a["data-cell"])

    def handle_data(self, data):
        if self._count is not None and data.strip():
            self.summary[self._count] = int(data.strip())
            self._count = None


@pytest.fixture(scope="module")
def pages(check_report, fmus, tmp_path_factory):
    """One page of each kind: check (the module's logs), run, campaign, falsification and pytest; the last three from
    their page writers on real results (a run's Result and log; campaign rows; a search's rows and its replayed log)."""
    import tiltload as tl
    from tiltload.master.app.evidence.campaign_page import write_campaign_report
    from tiltload.master.app.evidence.falsification_page import write_falsification_report
    from tiltload.master.app.evidence.pytest_report import TestRecord, write_pytest_report
    from tiltload.master.engine.requirement.files import load

    tmp = tmp_path_factory.mktemp("pages")
    reqs = tmp / "reqs.yaml"
    reqs.write_text("requirements:\n  - name: thrust\n    formula: always (controller.f_R >= 0 and controller.f_R <= 30)\n"
                    "  - name: x_close\n    formula: always (abs(plant.x - scenario.x_ref) < 0.2)\n")
    run = tl.run(scenario="fsi", controller="dlqr", stop_time=1.5, fmus=fmus, out=tmp, no_plots=True, requirements=reqs,
                 report=tmp / "run.html")
    rows = [{"run_id": k, "controller": "dlqr", "seed": k, "mass": 0.1 * k, "completed": k != 2, "diverged": k == 2,
             "diverged_at": None, "error": "plant: diverged" if k == 2 else None, "ISE(x)": 0.1 * k,
             "max_tracking_error": 0.2, "thrust_verdict": "PASS", "thrust_robustness": 1.0,
             "x_close_verdict": "FAIL" if k == 1 else "PASS (vacuous)", "x_close_robustness": -0.1 if k == 1 else 0.5}
            for k in range(4)]
    write_campaign_report("c", rows, ["mass"], ["tiltload run --seed 1"] * 4, [], tmp / "campaign.html")
    folder = tmp / "search"
    folder.mkdir()
    write_falsification_report("s", "falsification s", load(reqs), [("mass", "plant.m_L", 0.0, 1.0)],
                               [{"robustness": 0.3, "mass": 0.2}, {"robustness": -0.1, "mass": 0.7}], 1,
                               ["tiltload", "run"], run.log, [], folder)
    write_pytest_report([TestRecord("t.py::test_a", [run], "PASS"), TestRecord("t.py::test_b", [], "FAIL", "assert 0")],
                        tmp / "pytest.html", "a session")
    return {"check": check_report[1], "run": tmp / "run.html", "campaign": tmp / "campaign.html",
            "falsification": folder / "report.html", "pytest": tmp / "pytest.html"}


@pytest.mark.parametrize("kind", ["check", "run", "campaign", "falsification", "pytest"])
def test_each_kind_of_page_in_headless_chromium(pages, kind, tmp_path):
    """Chromium renders the page with no console message, and the counts and matrix cells it shows equal the JSON."""
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        pytest.skip("needs Debian's chromium (apt-get install chromium; .ci/run installs it)")
    page = pages[kind]
    run = subprocess.run([chromium, "--headless", "--no-sandbox", "--disable-gpu", "--enable-logging=stderr", "--v=0",
                          f"--user-data-dir={tmp_path / 'profile'}", "--dump-dom", page.as_uri()],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr[-2000:]
    console = [line for line in run.stderr.splitlines() if "CONSOLE" in line or "Uncaught" in line]
    assert not console, console
    dom = _Cells()
    dom.feed(run.stdout)
    data = _page_data(page)
    assert dom.summary == data["counts"]  # what the reader sees is what the JSON says
    assert sorted(dom.cells) == sorted(c for row in data["matrix"].values() for c in row.values())
    assert sum(data["counts"].values()) > 0


USER_TESTS = '''
import pytest

REQS = {reqs!r}


def test_the_loop_holds(tiltload_run):
    run = tiltload_run(controller="dlqr", scenario="fsi", stop_time=1.5, requirements=REQS)
    assert run.verdicts["thrust"] == "PASS"


def test_that_fails(tiltload_run):
    run = tiltload_run(controller="dlqr", scenario="fsi", stop_time=1.5, requirements=REQS)
    assert run.verdicts["x_close"] == "PASS", "x not close"


def test_without_runs():
    assert 1 + 1 == 2
'''


def test_the_plugin_s_report_has_a_section_per_test_and_junit_links_it(fmus, tmp_path):
    """A user's repository of three tests (two runs judged against requirements, one test without a run): the report
    counts what the runs' verdicts are (from the JSON the runs themselves give to pytest), the JUnit XML links it."""
    import sys
    import xml.etree.ElementTree as ET

    reqs = tmp_path / "reqs.yaml"
    reqs.write_text("requirements:\n  - name: thrust\n    formula: always (controller.f_R >= 0 and controller.f_R <= 30)\n"
                    "  - name: x_close\n    formula: always (abs(plant.x - scenario.x_ref) < 0.2)\n")
    repo = tmp_path / "repo"
    repo.mkdir()
    (repo / "test_user.py").write_text(USER_TESTS.format(reqs=str(reqs)))
    page, junit = tmp_path / "session.html", tmp_path / "junit.xml"
    run = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", f"--tiltload-fmus={fmus}",
                          f"--tiltload-report={page}", f"--junitxml={junit}", str(repo)],
                         cwd=repo, capture_output=True, text=True, timeout=600)
    assert run.returncode == 1, run.stdout[-3000:]  # one test fails
    data = _page_data(page)
    by_name = {t["name"].split("::")[-1]: t for t in data["tests"]}
    assert set(by_name) == {"test_the_loop_holds", "test_that_fails", "test_without_runs"}
    assert by_name["test_the_loop_holds"]["outcome"] == "PASS" and by_name["test_that_fails"]["outcome"] == "FAIL"
    assert "x not close" in by_name["test_that_fails"]["failure"] and not by_name["test_that_fails"]["error"]
    # the load starts 0.3 m off in x (the thesis's initial offset): x_close fails in both runs, thrust passes in both;
    # the test without a run counts its own PASS
    assert data["counts"]["FAIL"] == 2 and data["counts"]["PASS"] == 3
    assert all(t["command"].startswith("tiltload run ") for t in data["tests"] if t["name"] != by_name["test_without_runs"]["name"])
    properties = {p.get("name"): p.get("value") for p in ET.parse(junit).iter("property")}
    link, _, anchor = properties["tiltload_report"].partition("#")
    assert not Path(link).is_absolute() and (junit.parent / link).resolve() == page.resolve() and anchor.startswith("test-")
    # what the page names survives pytest's temporary folders: the runs' logs and replay folders copied beside it
    kept = page.parent / f"{page.stem}_files"
    for t in data["tests"]:
        if t["log"]:
            assert Path(t["log"]).is_file() and Path(t["log"]).resolve().is_relative_to(kept.resolve())
            words = shlex.split(t["command"])
            assert Path(words[words.index("--out") + 1]).resolve().is_relative_to(kept.resolve())


def test_a_diverged_signal_is_drawn_where_it_was_sane_and_the_divergence_marked():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from tiltload.master.app.views.plot import scale_to_sane

    t = np.linspace(0, 2.2, 221)
    y = np.sin(3 * t)
    y[-3:] = [1e30, 1e60, 1e90]  # the plant's blow-up in its last steps
    fig, ax = plt.subplots()
    ax.plot(t, y)
    ax.plot(t, 0.5 * np.cos(t))
    assert scale_to_sane(ax) == pytest.approx(t[-3])
    lo, hi = ax.get_ylim()
    assert -1.2 < lo < -0.9 and 0.9 < hi < 1.2  # the sine's own range, padded
    fig2, ax2 = plt.subplots()
    ax2.plot(t, 5 * t)  # a ramp grows, it does not diverge
    before = ax2.get_ylim()
    assert scale_to_sane(ax2) is None and ax2.get_ylim() == before
    plt.close(fig)
    plt.close(fig2)


def test_a_title_names_the_set_values_briefly():
    from tiltload.master.app.views.plot import case_title

    many = " ".join(f"plant.p{k}={k / 10}" for k in range(9))
    title = case_title({"vehicle": "load", "scenario": "fsi", "trajectory": "1", "controller": "dlqr", "seed": "1", "set": many})
    assert title.endswith("set plant.p0=0.0, plant.p1=0.1 (+7 more)")
    long = "plant.m_L=" + "9" * 200
    assert len(case_title({"vehicle": "load", "set": long})) < 90


def test_a_run_s_report_names_its_fmus_and_its_verdicts(fmus, tmp_path):
    """tiltload run --report: the verdicts are the run's own (the API's result objects), each FMU's SHA-256 is the file's,
    the replay command reruns the case."""
    import hashlib

    import tiltload as tl

    reqs = tmp_path / "reqs.yaml"
    reqs.write_text("requirements:\n  - name: thrust\n    formula: always (controller.f_R >= 0 and controller.f_R <= 30)\n"
                    "  - name: x_close\n    formula: always (abs(plant.x - scenario.x_ref) < 0.2)\n")
    page = tmp_path / "run.html"
    result = tl.run(scenario="fsi", controller="dlqr", stop_time=2, fmus=fmus, out=tmp_path, no_plots=True, requirements=reqs,
                    report=page)
    data = _page_data(page)
    assert {r["name"]: r["verdict"] for r in data["tests"][0]["results"]} == result.verdicts == {"thrust": "PASS", "x_close": "FAIL"}
    shown = {f["instance"]: f["sha256"] for f in data["environment"]["fmus"]}
    assert set(shown) == {"plant", "sensors", "scenario", "controller"}
    for inst in ("plant", "controller"):
        path = next(f["path"] for f in data["environment"]["fmus"] if f["instance"] == inst)
        assert shown[inst] == hashlib.sha256(open(path, "rb").read()).hexdigest()
    assert data["tests"][0]["command"].startswith("tiltload run --scenario fsi --controller dlqr --stop-time 2")
    assert "--report" not in data["tests"][0]["command"]
    assert data["counts"]["FAIL"] == 1 and data["counts"]["PASS"] == 1


def test_a_diverged_run_gets_its_figures_and_an_error_in_its_report(fmus, tmp_path, capsys):
    page = tmp_path / "div.html"
    code = main(["run", "--fmus", str(fmus), "--scenario", "fsi", "--controller", "dlqr", "--set", "plant.m_L=4",
                 "--allow-infeasible", "--stop-time", "4", "--out", str(tmp_path), "--quiet", "--report", str(page)])
    assert code == 1
    out = capsys.readouterr().out
    assert "plots: " in out and list(tmp_path.glob("*_remaining_dof.png"))  # the figures of what the log holds
    data = _page_data(page)
    assert data["counts"]["ERROR"] == 1 and "diverged" in data["tests"][0]["error"]


@pytest.mark.slow
def test_a_falsification_s_report_shows_its_counterexample_replayed(fmus, tmp_path):
    """altitude_thrust_loss, 20 CMA-ES simulations run to their stop time: the report's counterexample is the least
    robust row of falsification.parquet, replayed with a log: the same robustness, FAIL exactly when it is negative."""
    import pandas as pd
    import tiltload as tl

    spec = ROOT / "docs" / "falsification" / "altitude_thrust_loss.toml"
    out = tmp_path / "search"
    tl.falsify(spec, out=out, simulations=20, fmus=fmus, no_early_stop=True, branch="off", workers=1)
    rows = pd.read_parquet(out / "falsification.parquet")
    least = float(rows["robustness"].min())
    data = _page_data(out / "report.html")
    case = data["tests"][0]
    assert case["name"] == ("counterexample" if least < 0 else "least robust case")
    result = case["results"][0]
    assert result["robustness"] == pytest.approx(least, abs=1e-12)  # the replay is the evaluation, bit for bit
    assert result["verdict"] == ("FAIL" if least < 0 else "PASS") and data["counts"][result["verdict"]] == 1
    assert case["curves"] and case["command"].startswith("tiltload run ")


def test_a_vacuous_pass_is_named_in_the_report(tmp_path):
    """always (x > 5 implies x < 10) on an x that never exceeds 1: its trigger never held, the pass is vacuous (by the
    definition: the antecedent's robustness 1 - 5 < 0 at every sample); one whose trigger held passes plainly."""
    t = np.arange(2000) * TICK
    x = np.sin(t)
    log = write_log(tmp_path / "x.mcap", {"plant": (t, {"x": x})}, stop_time=float(t[-1]))
    assert (x - 5 <= 0).all() and (x - 0.5 > 0).any()
    reqs = tmp_path / "reqs.yaml"
    reqs.write_text("requirements:\n  - name: never_triggered\n    formula: always (plant.x > 5 implies plant.x < 10)\n"
                    "  - name: triggered\n    formula: always (plant.x > 0.5 implies plant.x < 10)\n")
    page = tmp_path / "v.html"
    assert main(["check", str(reqs), str(log), "--report", str(page)]) == 0
    data = _page_data(page)
    assert data["matrix"] == {"never_triggered": {"x": "PASS (vacuous)"}, "triggered": {"x": "PASS"}}
    assert data["counts"]["PASS (vacuous)"] == 1 and data["counts"]["PASS"] == 1


def test_a_large_campaign_page_lists_the_failed_runs_first_and_counts_every_run(tmp_path, monkeypatch):
    """Past LISTED runs the page shows LISTED one by one (failed or diverged, then failing a requirement, first), while
    its counts stay over every run: by the rows' own verdicts, counted here independently."""
    import json
    import re

    from tiltload.master.app.evidence import campaign_page

    monkeypatch.setattr(campaign_page, "LISTED", 3)
    rows = [{"run_id": k, "controller": "dlqr", "seed": k, "mass": 0.1 * k, "completed": k != 7, "diverged": k == 7,
             "diverged_at": None, "error": "plant: diverged" if k == 7 else None, "ISE(x)": 0.1 * k,
             "max_tracking_error": 0.2, "thrust_verdict": "FAIL" if k == 5 else "PASS", "thrust_robustness": -1.0 if k == 5 else 1.0}
            for k in range(10)]
    page = campaign_page.write_campaign_report("big", rows, ["mass"], [f"tiltload run --seed {k}" for k in range(10)], [],
                                               tmp_path / "big.html").read_text()
    data = json.loads(re.search(r'<script type="application/json"[^>]*>(.*?)</script>', page, re.S).group(1))
    assert [t["name"] for t in data["tests"]] == ["run 7", "run 5", "run 0"]
    assert data["total"] == 10 and 'data-tests="10"' in page and 'data-listed="3"' in page
    assert data["counts"]["PASS"] == 8 and data["counts"]["FAIL"] == 1 and data["counts"]["ERROR"] == 1
    assert "lists 3 of the 10 runs" in page

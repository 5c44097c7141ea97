"""Reports laid out for their readers (docs/reports.md): measured in headless Chromium over its DevTools protocol, no
page overflows at 1,400 px or at A4 width (the page's scroll width equals its client width) for a run, a check,
campaigns of 12 and 240 runs, a falsification and a pytest session of 50 tests; the first screen shows the JSON's
counts; the traceability matrix keeps requirements as rows and summarises what does not fit; the PDF holds every
requirement's name (pdftotext)."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path

import pytest
from support.chromium_page import Browser, chromium

WIDTHS = (1400, 794)  # a desktop window; A4's 210 mm at 96 px per inch
KINDS = ("run", "check", "campaign_12", "campaign_240", "falsification", "pytest_50")
REQS = ("requirements:\n"
        "  - name: thrust_within_the_actuator_limits\n    formula: always (controller.f_R >= 0 and controller.f_R <= 30)\n"
        "    source: \"thesis Table 5.2, the rotor's thrust limits (a long source to wrap: actuator saturation bounds)\"\n"
        "  - name: x_close\n    formula: always (abs(plant.x - scenario.x_ref) < 0.2)\n    source: test, a tight band\n")


def _data(path: Path) -> dict:
    text = path.read_text(encoding="utf-8")
    return json.loads(re.search(r'<script type="application/json" id="tiltload-results">(.*?)</script>', text, re.S).group(1))


def _rows(n: int) -> list[dict]:
    """n campaign rows: every 5th fails x_close, run 2 failed; a long varied name to stress the width."""
    return [{"run_id": 1_000_000_000_000_000 + k, "controller": "dlqr", "seed": k, "mass_of_the_suspended_load": 0.1 * k,
             "completed": k != 2, "diverged": k == 2, "diverged_at": None, "error": "plant: diverged" if k == 2 else None,
             "ISE(x)": 0.1 * k, "max_tracking_error": 0.2, "thrust_within_the_actuator_limits_verdict": "PASS",
             "thrust_within_the_actuator_limits_robustness": 1.0, "x_close_verdict": "FAIL" if k % 5 == 1 else "PASS",
             "x_close_robustness": -0.1 if k % 5 == 1 else 0.5} for k in range(n)]


@pytest.fixture(scope="module")
def pages(fmus, tmp_path_factory):
    import tiltload as tl
    from tiltload.master.app.cli import main
    from tiltload.master.app.evidence.campaign_page import write_campaign_report
    from tiltload.master.app.evidence.falsification_page import write_falsification_report
    from tiltload.master.app.evidence.pytest_report import TestRecord, write_pytest_report
    from tiltload.master.engine.requirement.files import load

    tmp = tmp_path_factory.mktemp("layout")
    reqs = tmp / "reqs.yaml"
    reqs.write_text(REQS)
    run = tl.run(scenario="fsi", controller="dlqr", stop_time=1.5, fmus=fmus, out=tmp, no_plots=True, requirements=reqs,
                 report=tmp / "run.html")
    assert main(["check", str(reqs), str(run.log), "--report", str(tmp / "check.html")]) in (0, 1)
    for n in (12, 240):
        rows = _rows(n)
        write_campaign_report("c", rows, ["mass_of_the_suspended_load"], [f"tiltload run --seed {k}" for k in range(n)],
                              [], tmp / f"campaign_{n}.html", requirements=load(reqs))
    folder = tmp / "search"
    folder.mkdir()
    write_falsification_report("s", "falsification s", load(reqs), [("mass", "plant.m_L", 0.0, 1.0)],
                               [{"robustness": 0.3, "mass": 0.2}, {"robustness": -0.1, "mass": 0.7}], 1,
                               ["tiltload", "run"], run.log, [], folder)
    records = [TestRecord(f"tests/test_a_rather_long_module_name.py::test_case_{k}[parameter-set-{k}-with-a-long-id]",
                          [run] if k < 2 else [], "FAIL" if k % 7 == 3 else "PASS", "assert 0" if k % 7 == 3 else None)
               for k in range(50)]
    write_pytest_report(records, tmp / "pytest_50.html", "a session of 50 tests")
    return {"run": tmp / "run.html", "check": tmp / "check.html", "campaign_12": tmp / "campaign_12.html",
            "campaign_240": tmp / "campaign_240.html", "falsification": folder / "report.html",
            "pytest_50": tmp / "pytest_50.html"}, reqs


@pytest.fixture(scope="module")
def browser():
    if chromium() is None:
        pytest.skip("needs Debian's chromium (apt-get install chromium; .ci/run installs it)")
    b = Browser()
    yield b
    b.close()


WIDTH = "[document.documentElement.scrollWidth, document.documentElement.clientWidth]"
# what a reader sees on the first screen (the top 900 px): the verdict counts shown there
FIRST_SCREEN = """(() => { const out = {};
  for (const d of document.querySelectorAll('div.count[data-verdict]'))
    if (d.getBoundingClientRect().bottom <= innerHeight) out[d.dataset.verdict] = parseInt(d.querySelector('b').textContent);
  const v = document.querySelector('[data-overall]'), c = document.querySelector('[data-tested="controller"]');
  return {counts: out, overall: v && v.getBoundingClientRect().bottom <= innerHeight ? v.textContent : null,
          controller: c ? c.textContent : null}; })()"""


@pytest.mark.parametrize("kind", KINDS)
def test_no_page_overflows_at_desktop_or_a4_width(pages, browser, kind):
    for width in WIDTHS:
        scroll, client = browser.measure(pages[0][kind], width, WIDTH)
        print(f"{kind} at {width} px: scrollWidth {scroll}, clientWidth {client}")
        assert scroll == client, f"{kind} at {width} px: the page is {scroll} px wide in {client}"


@pytest.mark.parametrize("kind", KINDS)
def test_the_first_screen_shows_the_json_s_counts_and_the_overall_verdict(pages, browser, kind):
    data = _data(pages[0][kind])
    seen = browser.measure(pages[0][kind], 1400, FIRST_SCREEN)
    assert seen["counts"] == data["counts"]
    worst = next((v for v in ("FAIL", "ERROR", "INCONCLUSIVE", "ZERO") if data["counts"][v]), "PASS")
    assert seen["overall"] == worst
    fmus = data["environment"]["fmus"] or [f for t in data["tests"] if t["environment"] for f in t["environment"]["fmus"]]
    controller = [f for f in fmus if f["instance"] == "controller"]
    if controller:  # the digest the FMU record holds is the one on the first screen
        assert controller[0]["sha256"] in seen["controller"]


# per requirement row: its shown cells and the counts of the summarised tests
MATRIX = """(() => { const out = {};
  for (const tr of document.querySelectorAll('table.matrix tr')) {
    const th = tr.querySelector('th.req'); if (!th) continue;
    const row = out[th.textContent] = {cells: [], rest: {}, source: tr.querySelector('td.source').textContent};
    for (const td of tr.querySelectorAll('td[data-cell]')) row.cells.push(td.dataset.cell);
    for (const s of tr.querySelectorAll('[data-rest]')) row.rest[s.dataset.rest] = parseInt(s.dataset.n);
  }
  return {rows: out, columns: [...document.querySelectorAll('table.matrix tr:first-child th')].map(th => th.textContent)}; })()"""


@pytest.mark.parametrize("kind", ("run", "campaign_12", "campaign_240", "pytest_50"))
def test_the_matrix_has_requirements_as_rows_and_counts_what_does_not_fit(pages, browser, kind):
    from tiltload.master.engine.requirement.files import load

    data = _data(pages[0][kind])
    seen = browser.measure(pages[0][kind], 1400, MATRIX)
    declared = {r.name: r.source for r in load(pages[1])}
    assert set(seen["rows"]) == set(data["matrix"])
    assert len(seen["columns"]) <= 2 + 12 + 1  # requirement, source, 12 tests, the rest
    for name, row in seen["rows"].items():
        assert row["source"] == declared.get(name, row["source"])  # the requirement file's source, campaigns too
        every = list(data["matrix"][name].values())
        assert len(row["cells"]) + sum(row["rest"].values()) == len(every)
        for verdict in set(every):
            assert row["cells"].count(verdict) + row["rest"].get(verdict, 0) == every.count(verdict)
        if "FAIL" in every:  # failing ones first
            assert row["cells"][0] in ("FAIL", "ERROR") or "FAIL" not in data["matrix"][name].values()
    assert all(re.fullmatch(r"[RT]\d+", c) for c in seen["columns"][2:14] if not c.startswith("the other"))


def test_the_pdf_holds_every_requirement_and_has_pages(pages, tmp_path):
    """--report X.pdf: the HTML beside it and the PDF headless Chromium printed; pdftotext reads every name in it."""
    if chromium() is None or shutil.which("pdftotext") is None:
        pytest.skip("needs chromium and pdftotext (poppler-utils)")
    from tiltload.master.app.cli import main
    from tiltload.master.engine.requirement.files import load

    run_html = pages[0]["run"]
    log = Path(_data(run_html)["tests"][0]["log"])
    pdf = tmp_path / "check.pdf"
    assert main(["check", str(pages[1]), str(log), "--report", str(pdf)]) in (0, 1)
    assert pdf.read_bytes().startswith(b"%PDF") and (tmp_path / "check.html").is_file()
    info = subprocess.run(["pdfinfo", str(pdf)], capture_output=True, text=True).stdout if shutil.which("pdfinfo") else ""
    pages_n = int(re.search(r"Pages:\s+(\d+)", info).group(1)) if info else None
    print(f"check.pdf: {pages_n} pages")
    assert pages_n is None or pages_n >= 2
    text = subprocess.run(["pdftotext", "-layout", str(pdf), "-"], capture_output=True, text=True, check=True).stdout
    flat = re.sub(r"\s+", "", text)
    for req in load(pages[1]):
        assert re.sub(r"\s+", "", req.name) in flat, req.name


# a requirement's figure: its title's lines, whether any of its text leaves the figure, the bounds in the page's data
FIGURE = """(() => { const out = {};
  for (const f of document.querySelectorAll('figure[aria-label^="requirement "]')) {
    const svg = f.querySelector('svg'), box = svg.getBoundingClientRect();
    const texts = [...svg.querySelectorAll('text')];
    out[f.getAttribute('aria-label').slice(12)] = {text: texts.map(t => t.textContent).join(' '),
      cut: texts.filter(t => { const r = t.getBoundingClientRect(); return r.left < box.left - 1 || r.right > box.right + 1; }).length};
  }
  return out; })()"""


def test_a_failing_requirement_s_figure_is_titled_in_full_with_its_bound_on_its_signal(pages, browser):
    from tiltload.master.engine.requirement.files import load

    page = pages[0]["run"]
    data = _data(page)
    test = data["tests"][0]
    verdicts = {r["name"]: r["verdict"] for r in test["results"]}
    assert verdicts["x_close"] == "FAIL"
    seen = browser.measure(page, 794, FIGURE)
    for req in load(pages[1]):
        figure = seen[req.name]
        assert f"{req.name}: {verdicts[req.name]}" in figure["text"]
        assert re.sub(r"\s+", "", req.text) in re.sub(r"\s+", "", figure["text"])  # the formula in full ...
        assert figure["cut"] == 0  # ... and none of the figure's text beyond its edge, at A4 width
    # the bounds the requirement file states, on the signals they bound: f_R in [0, 30]; plant.x within x_ref ± 0.2
    thrust = test["curves"]["thrust_within_the_actuator_limits"]
    assert sorted({v for c in thrust if c["label"] == "bound on controller.f_R" for v in c["values"]}) == [0, 30]
    x = [c for c in test["curves"]["x_close"] if c["label"] == "bound on plant.x"]
    ref = next(c for c in test["curves"]["x_close"] if c["label"] == "scenario.x_ref")
    assert len(x) == 2
    for curve, c in zip(sorted(x, key=lambda k: k["values"][0]), (-0.2, 0.2)):
        assert curve["times"] == ref["times"]
        assert curve["values"] == pytest.approx([v + c for v in ref["values"]], abs=1e-6)


GAIN = """[...document.querySelectorAll('table.gain[data-matrix="K"] tr')].slice(1).map(
  tr => [...tr.querySelectorAll('td')].map(td => td.textContent))"""


def test_a_gain_matrix_reads_as_a_matrix_in_numeric_order(browser, tmp_path):
    """K_i_j (3 x 11) shown as a matrix: row i, column j holds K_i_j's value, 10 after 9, not text-sorted."""
    from tiltload.master.app.evidence import Report, write_report
    from tiltload.master.app.evidence.model import this_environment

    gains = {f"K_{i}_{j}": str(100 * i + j) for i in range(3) for j in range(11)}
    env = this_environment((), [("Tc", "0.012"), *sorted(gains.items())])  # text-sorted, as a record lists them
    page = write_report(Report("gains", "run", [], env), tmp_path / "gains.html")
    assert browser.measure(page, 1400, GAIN) == [[str(100 * i + j) for j in range(11)] for i in range(3)]


def test_without_chromium_the_pdf_is_refused_in_one_line_and_the_page_written(tmp_path, monkeypatch):
    from tiltload.master.app.evidence import Report, paper, write_report
    from tiltload.master.app.evidence.model import this_environment
    from tiltload.master.app.user_error import UserError

    monkeypatch.setattr(paper, "chromium", lambda: None)
    with pytest.raises(UserError) as err:
        write_report(Report("no browser", "check", [], this_environment()), tmp_path / "r.pdf")
    assert "\n" not in str(err.value) and "Chromium is not installed" in str(err.value)
    assert (tmp_path / "r.html").is_file() and not (tmp_path / "r.pdf").exists()

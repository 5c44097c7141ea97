"""Issue 61's contradictions: two faces over the same case say the same thing.

A campaign whose left rotor's thrust is scaled by -1e30 or -1e29 from t = 1 s in two of its runs (the plant's state is then not
finite: diverged): its
requirement counts are the same in the terminal, report.md, report.html, the results Parquet and tl.campaign's result,
and a diverged run counts as ERROR, never as a FAIL with a NaN robustness.
"""

from __future__ import annotations

import json
import math
import re
from html.parser import HTMLParser

import pyarrow.parquet as pq
import pytest
import tiltload as tl
from tiltload.master.app.cli import main

SPEC = """
name = "blown-up"
[base]
scenario = "fsi"
trajectory = 1
controllers = ["dlqr"]
stop_time = 2.5
faults = [{action = "scale", target = "plant.f_L", value = 1.0, start = 1.0}]
[vary]
seeds = [1]
[[vary.parameters]]
name = "thrust_left"
targets = ["faults.0.value"]
values = [1.0, -1e30, -1e29]
[keep]
requirements = "reqs.yaml"
"""
REQS = """requirements:
  - {name: near, formula: "always abs(plant.x) <= 50"}
"""
# what each run does, known independently of the counts: the unfaulted run flies, the two blown-up ones diverge
EXPECTED = {"PASS": 1, "FAIL": 0, "INCONCLUSIVE": 0, "ZERO": 0, "ERROR": 2}


class _Tables(HTMLParser):
    """Every <table>'s rows as lists of cell texts, with the text just before the table (its title)."""

    def __init__(self):
        super().__init__()
        self.tables, self._text, self._cell, self._row = [], "", None, None

    def handle_starttag(self, tag, attrs):
        if tag == "table":
            self.tables.append((self._text.strip(), []))
        elif tag == "tr" and self.tables:
            self._row = []
            self.tables[-1][1].append(self._row)
        elif tag in ("td", "th"):
            self._cell = ""

    def handle_endtag(self, tag):
        if tag in ("td", "th") and self._row is not None and self._cell is not None:
            self._row.append(self._cell.strip())
            self._cell = None
        elif tag in ("h2", "h3", "caption", "summary", "p"):
            pass

    def handle_data(self, data):
        if self._cell is not None:
            self._cell += data
        elif data.strip():
            self._text = data


@pytest.mark.slow
def test_a_diverged_campaign_s_requirement_counts_agree_in_every_face(fmus, tmp_path, capsys):
    (tmp_path / "reqs.yaml").write_text(REQS)
    spec = tmp_path / "blown.toml"
    spec.write_text(SPEC)
    out = tmp_path / "out"
    api = tl.campaign(spec, out=out, workers=1, fmus=fmus, progress=lambda _: None)
    rows = pq.read_table(api.results).to_pylist()
    diverged = [r for r in rows if r["diverged"]]
    assert [r["thrust_left"] for r in diverged] == [-1e30, -1e29] and all(r["diverged_at"] >= 1.0 for r in diverged)

    # the Parquet: ERROR in the verdict column of the diverged runs
    verdicts = [r["near_verdict"] for r in rows]
    assert {v: verdicts.count(v) for v in EXPECTED} == EXPECTED
    # the API's object
    (near,) = api.requirements
    assert near.name == "near" and near.counts == EXPECTED
    assert near.least_robustness is not None and math.isfinite(near.least_robustness)
    light = next(r for r in rows if not r["diverged"])
    assert near.least_robustness == light["near_robustness"]  # the only run that judged it

    # the terminal (the runs are stored: the command line reads the same results)
    capsys.readouterr()
    assert main(["campaign", str(spec), "--out", str(out), "--fmus", str(fmus), "--workers", "1"]) == 1  # runs failed
    said = capsys.readouterr()
    line = next(x for x in said.out.splitlines() if x.startswith("requirement near:"))
    assert {v: int(re.search(rf"(\d+) {v}\b", line).group(1)) for v in EXPECTED} == EXPECTED
    assert "FAILed" not in said.err and "2 run(s) failed" in said.err

    # report.md
    text = (out / "report.md").read_text()
    header = next(x for x in text.splitlines() if x.startswith("| requirement |"))
    md_row = next(x for x in text.splitlines() if x.startswith("| near |"))
    cells = dict(zip([c.strip() for c in header.strip("|").split("|")], [c.strip() for c in md_row.strip("|").split("|")]))
    assert {v: int(cells[v]) for v in EXPECTED} == EXPECTED
    assert float(cells["least robustness"]) == pytest.approx(light["near_robustness"], rel=1e-3)

    # report.html: its table, parsed
    parser = _Tables()
    parser.feed((out / "report.html").read_text(encoding="utf-8"))
    table = next(rows_ for _, rows_ in parser.tables if rows_ and rows_[0][:2] == ["requirement", "PASS"])
    html = dict(zip(table[0], next(r for r in table[1:] if r[0] == "near")))
    assert {"PASS": int(html["PASS"]) + int(html["PASS (vacuous)"]),
            **{v: int(html[v]) for v in EXPECTED if v != "PASS"}} == EXPECTED
    assert float(html["least robustness"]) == pytest.approx(light["near_robustness"], rel=1e-3)

    # report.html's JSON (its first screen's counts: each run counted once, a diverged one as ERROR) and its matrix
    page = (out / "report.html").read_text(encoding="utf-8")
    data = json.loads(re.search(r'id="tiltload-results">(.*?)</script>', page, re.S).group(1))
    assert data["counts"] == {**dict.fromkeys(data["counts"], 0), **EXPECTED}
    assert sorted(data["matrix"]["near"].values()) == ["ERROR", "ERROR", "PASS"]
    for r in diverged:  # each ERROR with its reason and the time the run diverged (the Parquet's diverged_at)
        test = next(t for t in data["tests"] if t["name"] == f"run {r['run_id']}")
        assert test["results"] == [] and "diverged" in test["error"] and f"{r['diverged_at']:.3f}" in test["error"]


DIVERGED_RUN = ["--scenario", "fsi", "--trajectory", "1", "--controller", "dlqr", "--set", "plant.m_L=6", "--allow-infeasible",
                "--stop-time", "3"]  # a 6 kg load: the plant's state diverges at 1.512 s
TWO = 'requirements:\n  - {name: near, formula: "always abs(plant.x) <= 50"}\n  - {name: up, formula: "always[0:1] plant.z > -100"}\n'


@pytest.mark.slow
def test_a_diverged_run_is_error_in_every_face(fmus, tmp_path, capsys):
    """A single run that diverged: each requirement ERROR, with the time it diverged and why, never the FAIL of its
    blown-up values, in the run's terminal table, `check` (table and JSON), report.html (its JSON and matrix) and the
    API (tl.run raises the run's line; tl.check and tl.open_log of its log say ERROR)."""
    reqs = tmp_path / "reqs.yaml"
    reqs.write_text(TWO)
    code = main(["run", *DIVERGED_RUN, "--fmus", str(fmus), "--out", str(tmp_path), "--name", "d", "--no-plots",
                 "--requirements", str(reqs), "--report", str(tmp_path / "d.html")])
    out, err = capsys.readouterr()
    assert code == 1 and "diverged" in err
    log = tmp_path / "d.mcap"
    end = tl.open_log(log).signals("/plant").time[-1]  # where the log's plant stops: the divergence
    assert 1.0 < end < 3.0
    at = f"t={end:.3f} s"

    def rows(text: str) -> dict[str, str]:
        return {line.split()[0]: line.split()[1] for line in text.splitlines() if line.startswith(("  near ", "  up "))}

    assert rows(out) == {"near": "ERROR", "up": "ERROR"} and at in out
    assert main(["check", str(reqs), str(log)]) == 1  # a run that failed: as the run's own exit code
    said = capsys.readouterr().out
    assert rows(said) == {"near": "ERROR", "up": "ERROR"}
    assert main(["check", "--json", str(reqs), str(log)]) == 1
    results = json.loads(capsys.readouterr().out)["logs"][0]["results"]
    assert [(r["verdict"], r["robustness"], r["first_violation"]) for r in results] == [("ERROR", None, None)] * 2
    assert all(at in r["why"] and "diverged" in r["why"] for r in results)

    page = (tmp_path / "d.html").read_text(encoding="utf-8")
    data = json.loads(re.search(r'id="tiltload-results">(.*?)</script>', page, re.S).group(1))
    assert data["counts"]["ERROR"] == 1 and sum(data["counts"].values()) == 1  # the run, once
    assert {name: set(row.values()) for name, row in data["matrix"].items()} == {"near": {"ERROR"}, "up": {"ERROR"}}
    assert 'data-overall="ERROR"' in page and at in data["tests"][0]["error"]

    with pytest.raises(tl.TiltloadError, match=f"diverged.*{at}"):  # tl.run: a run that failed raises its line
        tl.run(scenario="fsi", trajectory=1, controller="dlqr", set=(("plant.m_L", 6.0),), allow_infeasible=True, stop_time=3,
               fmus=fmus, out=tmp_path / "api", no_plots=True, quiet=True, requirements=reqs)
    assert [r.verdict for r in tl.check(log, reqs)] == ["ERROR", "ERROR"] == list(tl.open_log(log).verdicts.values())


@pytest.mark.slow
def test_the_campaign_report_is_titled_by_the_spec_and_names_the_page_it_writes(fmus, tmp_path, capsys):
    """Results in a folder named otherwise than the spec: the reports take the spec's name; campaign-report says the
    report.html it rewrites (the page is written anew: its time changes), not only report.md."""
    import os

    (tmp_path / "c.toml").write_text(FMU_SPEC.replace('controllers = ["dlqr", "mine.fmu"]', 'controllers = ["dlqr"]'))
    results = tl.campaign(tmp_path / "c.toml", out=tmp_path / "elsewhere", workers=1, fmus=fmus,
                          progress=lambda _: None).results
    page = results.parent / "report.html"
    os.utime(page, (0, 0))
    capsys.readouterr()
    assert main(["campaign-report", str(results)]) == 0
    said = capsys.readouterr().out
    assert str(page) in said and "report.md" in said and page.stat().st_mtime > 0
    assert (results.parent / "report.md").read_text().startswith("# Campaign report: two-builds\n")
    title = re.search(r"<title>(.*?)</title>", page.read_text(encoding="utf-8"), re.S).group(1)
    assert "two-builds" in title and "elsewhere" not in title


FMU_SPEC = """
name = "two-builds"
[base]
scenario = "fsi"
trajectory = 1
controllers = ["dlqr", "mine.fmu"]
stop_time = 1.0
[vary]
seeds = [1]
"""


def _environment_rows(page: str) -> list[list[str]]:
    """The rows of report.html's FMU table in its Environment section (instance, model, GUID, SHA-256)."""
    parser = _Tables()
    parser.feed(page[page.index('id="environment"'):])
    return next(rows_[1:] for _, rows_ in parser.tables if rows_ and "SHA-256" in " ".join(rows_[0]))


@pytest.mark.slow
def test_the_campaign_report_names_the_sha256_of_each_fmu_it_ran(fmus, tmp_path):
    """A campaign of our dlqr and a user's controller FMU (another build: its own SHA-256): report.html's environment
    and report.md name every FMU the runs loaded, each with the digest of its file."""
    import hashlib
    import shutil
    import zipfile

    mine = tmp_path / "mine.fmu"
    shutil.copy(fmus / "TiltloadController.fmu", mine)
    with zipfile.ZipFile(mine, "a") as z:  # another build of the same controller: another file
        z.comment = b"the user's build"
    (tmp_path / "two.toml").write_text(FMU_SPEC)
    result = tl.campaign(tmp_path / "two.toml", out=tmp_path / "out", workers=1, fmus=fmus, progress=lambda _: None)
    loop = [fmus / f"Tiltload{n}.fmu" for n in ("Plant", "Sensors", "Scenario", "Controller")]  # (the folder may hold more)
    digest = {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in [*loop, mine]}
    assert len(set(digest.values())) == 5

    rows = _environment_rows((result.results.parent / "report.html").read_text(encoding="utf-8"))
    named = {r[0]: r[-1] for r in rows}
    assert named == {"plant": digest["TiltloadPlant.fmu"], "sensors": digest["TiltloadSensors.fmu"],
                     "scenario": digest["TiltloadScenario.fmu"], "controller (dlqr)": digest["TiltloadController.fmu"],
                     "controller (mine)": digest["mine.fmu"]}
    text = (result.results.parent / "report.md").read_text()
    assert "not recorded" not in text.lower() and all(f"`{d}`" in text for d in named.values())

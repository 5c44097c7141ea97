"""A campaign's keep.requirements: every run's verdict and robustness are Parquet columns, equal to the offline check of
the run's log; a bad requirement file is the spec's one line."""

from __future__ import annotations

import json
import math

import pyarrow.parquet as pq
import pytest
from tiltload.master.app.campaign import runner as campaign
from tiltload.master.app.campaign import spec as campaign_spec
from tiltload.master.engine.requirement.check import check_log
from tiltload.master.engine.requirement.files import load

SPEC = """
name = "reqs"
[base]
scenario = "zse"
trajectory = 1
controllers = ["mixed"]
stop_time = 1.5
[vary]
seeds = [1, 2]
[keep]
logs = true
requirements = "reqs.yaml"
"""
REQS = """requirements:
  - {name: thrust, bounds: {signal: controller.f_R, min: 0, max: 30}}
  - name: tilt_rates
    formula: always (plant.alpha_R_dot >= controller.est_alpha_R_dot_lo and plant.alpha_R_dot <= controller.est_alpha_R_dot_hi)
  - {name: later, formula: "eventually[0:5] plant.z > 100"}
  - {name: tight, formula: "always abs(plant.x - scenario.x_ref) < 0.0001"}
"""


@pytest.mark.slow
def test_requirement_columns_equal_the_offline_check(fmus, tmp_path):
    (tmp_path / "reqs.yaml").write_text(REQS)
    spec = tmp_path / "c.toml"
    spec.write_text(SPEC)
    results, counts = campaign.run(spec, tmp_path / "out", workers=1, fmus=fmus, progress=lambda _: None)
    assert counts["completed"] == 2
    reqs = load(tmp_path / "reqs.yaml")
    for row in pq.read_table(results).to_pylist():
        logs = list((tmp_path / "out").rglob(f"{row['run_id']}.mcap"))
        assert len(logs) == 1
        for r in check_log(logs[0], reqs):
            assert row[f"{r.name}_verdict"] == r.verdict
            got = row[f"{r.name}_robustness"]
            assert (math.isnan(got) and r.robustness is None) or got == r.robustness
            at = row[f"{r.name}_first_violation"]  # a FAIL's first violation and the signals there, as check says
            assert (math.isnan(at) and r.first_violation is None) or at == r.first_violation
            assert json.loads(row[f"{r.name}_values"]) == (r.values if r.first_violation is not None else {})
        assert row["later_verdict"] == "INCONCLUSIVE" and row["thrust_verdict"] == "PASS" and row["tight_verdict"] == "FAIL"
    from tiltload.master.app.campaign.report import report

    text = report(results).read_text()
    assert "| thrust | 2 | 0 | 0 | 0 | 0 | 100 % |" in text and "| later | 0 | 0 | 2 | 0 | 0 | 0 % | — |" in text
    assert "### thrust: the least robust runs" in text and "tiltload run" in text
    # report.html: the FAIL rows give the first violation and the signals there, in the summary's table and each run's
    page = (results.parent / "report.html").read_text(encoding="utf-8")
    table = page[page.index("<h3>First violations</h3>"):].split("</table>")[0]
    for row in pq.read_table(results).to_pylist():
        values = json.loads(row["tight_values"])
        assert set(values) == {"plant.x", "scenario.x_ref"}
        there = ", ".join(f"{k} = {v:.6g}" for k, v in values.items())
        assert f"<td>{row['run_id']}</td><td>tight</td><td>{row['tight_first_violation']:.6g}</td><td>{there}</td>" in table


@pytest.mark.parametrize("reqs, needle", [
    ("requirements:\n  - {name: a-b, formula: \"plant.x > 0\"}\n", "names a column"),
    ("requirements:\n  - {name: a, formula: \"always[0:1 plant.x > 0\"}\n", "keep.requirements:"),
])
def test_a_bad_requirement_file_is_the_spec_s_error(tmp_path, reqs, needle):
    (tmp_path / "reqs.yaml").write_text(reqs)
    spec = tmp_path / "c.toml"
    spec.write_text(SPEC)
    with pytest.raises(campaign_spec.SpecError, match=needle):
        campaign_spec.load(spec)

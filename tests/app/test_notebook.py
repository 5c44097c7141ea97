"""docs/examples/evidence.ipynb executed by a real kernel (nbclient, ipykernel): its saved outputs hold the rich HTML
display of a run, a comparison and a campaign (the reports' content: no script, nothing fetched), whose verdict counts
equal what the run's log, the baseline's metrics and the campaign's results file say, read here on their own."""

from __future__ import annotations

import json
import re

import pyarrow.parquet as pq
import pytest
import tiltload as tl
from support import ROOT

NOTEBOOK = ROOT / "docs" / "examples" / "evidence.ipynb"
COUNTED = ("PASS", "FAIL", "INCONCLUSIVE", "PASS (vacuous)", "ZERO", "ERROR")


def shown_counts(html: str) -> dict[str, int]:
    """The summary's counts as the display shows them (its count boxes: data-verdict, then the number)."""
    found = {v: int(n) for v, n in re.findall(r'class="count[^"]*" data-verdict="([^"]+)"><b>(\d+)</b>', html)}
    assert set(found) == set(COUNTED), found
    return found


def tally(verdicts) -> dict[str, int]:
    return {v: sum(1 for x in verdicts if x == v) for v in COUNTED}


@pytest.fixture(scope="module")
def executed(fmus, tmp_path_factory):
    """The notebook run in a fresh folder (the FMUs the session built as its fmus/), saved, and read back."""
    import nbformat
    from nbclient import NotebookClient

    folder = tmp_path_factory.mktemp("notebook")
    (folder / "fmus").symlink_to(fmus, target_is_directory=True)
    nb = nbformat.read(NOTEBOOK, as_version=4)
    assert all(not c.get("outputs") for c in nb.cells if c.cell_type == "code"), "the shipped notebook keeps no outputs"
    NotebookClient(nb, timeout=300, kernel_name="python3", resources={"metadata": {"path": str(folder)}}).execute()
    nbformat.write(nb, folder / "executed.ipynb")
    saved = nbformat.read(folder / "executed.ipynb", as_version=4)
    shown = {}
    for cell in saved.cells:
        if cell.cell_type != "code":
            continue
        last = cell.source.strip().splitlines()[-1]
        html = [o["data"]["text/html"] for o in cell.outputs
                if o.get("output_type") == "execute_result" and "text/html" in o.get("data", {})]
        errors = [o for o in cell.outputs if o.get("output_type") == "error"]
        assert not errors, errors
        if html:
            shown[last] = html[0]
    return folder, shown


@pytest.mark.slow
def test_the_notebook_shows_a_run_a_comparison_and_a_campaign_as_static_html(executed):
    _, shown = executed
    assert set(shown) == {"run", "comparison", "campaign"}
    for html in shown.values():
        assert html.startswith('<div class="tiltload-report">')
        assert "<script" not in html.lower() and "<iframe" not in html.lower()
        assert not re.search(r'(src|href)="(?!data:|#)', html), "something fetched"


@pytest.mark.slow
def test_the_runs_display_counts_its_logs_verdicts(executed):
    folder, shown = executed
    verdicts = tl.open_log(folder / "runs" / "notebook" / "seed1.mcap").verdicts  # judged again from the log's record
    assert set(verdicts) == {"track_x", "thrust"}
    assert shown_counts(shown["run"]) == tally(verdicts.values())
    for name in verdicts:
        assert f'data-cell="{verdicts[name]}"' in shown["run"] and f">{name}<" in shown["run"]


@pytest.mark.slow
def test_the_comparisons_display_says_which_metrics_differ(executed):
    folder, shown = executed
    baseline = json.loads((folder / "runs" / "notebook" / "baseline.json").read_text())
    other = tl.open_log(folder / "runs" / "notebook" / "seed2.mcap").metrics
    rtol, atol = baseline["tolerances"]["rtol"], baseline["tolerances"]["atol"]
    differ = {k for k, b in baseline["metrics"].items() if not abs(other[k] - b) <= atol + rtol * abs(b)}
    counts = shown_counts(shown["comparison"])
    assert counts == tally(["FAIL" if differ else "PASS"])
    rows = re.findall(r"<tr><td>([^<]+)</td>(?:<td>[^<]*</td>){6}<td>(ok|DIFFERS|MISSING)</td></tr>", shown["comparison"])
    assert {m for m, status in rows if status != "ok"} == differ and len(rows) == len(baseline["metrics"])


@pytest.mark.slow
def test_the_campaigns_display_counts_its_results_file(executed):
    folder, shown = executed
    rows = pq.read_table(folder / "runs" / "notebook" / "campaign" / "results.parquet").to_pylist()
    assert len(rows) == 4
    cells = []
    for row in rows:
        if row.get("error") or not row.get("completed"):
            cells.append("ERROR")  # once a run: a run that failed judged nothing
            continue
        cells += [row[f"{name}_verdict"] for name in ("track_x", "thrust")]
    assert shown_counts(shown["campaign"]) == tally(cells)
    assert f'data-tests="{len(rows)}"' in shown["campaign"]


@pytest.mark.slow
def test_a_checks_display_counts_its_verdicts(executed):
    folder, _ = executed
    verdicts = tl.check(folder / "runs" / "notebook" / "seed2.mcap", folder / "notebook_reqs.yaml")
    assert isinstance(verdicts, list) and len(verdicts) == 2
    html = verdicts._repr_html_()
    assert shown_counts(html) == tally(r.verdict for r in verdicts) and "<script" not in html

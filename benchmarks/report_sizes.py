"""The five kinds of HTML report (docs/reports.md): the size of each and the time to write it, on this machine.

    python benchmarks/report_sizes.py --campaign RESULTS.parquet --falsification OUT_FOLDER [--fmus fmus]

run: a 40 s ZSE run with the thesis's 13 requirements (the report's time: the run with --report less the run
without); check: the same log (write_report alone); campaign: campaign-report of RESULTS (report.md, its figures and
report.html); falsification: report.html of a search's output folder written again (its best case replayed);
pytest: a session of two tests with runs of 10 s, with --tiltload-report less without.
"""

from __future__ import annotations

import argparse
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
REQS = ROOT / "docs" / "requirements" / "thesis.yaml"


def timed(fn):
    started = time.perf_counter()
    value = fn()
    return value, time.perf_counter() - started


def size(path: Path) -> str:
    return f"{path.stat().st_size / 1e6:.2f} MB"


def run_and_check(fmus: Path, tmp: Path) -> list[str]:
    import tiltload as tl
    from tiltload.master.app.evidence import Report, test_of_log, write_report
    from tiltload.master.app.evidence.model import this_environment
    from tiltload.master.engine.requirement.check import check_log
    from tiltload.master.engine.requirement.files import load

    common = {"scenario": "zse", "trajectory": 1, "stop_time": 40, "fmus": fmus, "no_plots": True, "requirements": REQS}
    _, plain = timed(lambda: tl.run(out=tmp / "a", **common))
    result, with_report = timed(lambda: tl.run(out=tmp / "b", report=tmp / "run.html", **common))
    reqs = load(REQS)
    results = check_log(result.log, reqs)
    _, check = timed(lambda: write_report(Report("check", "check", [test_of_log(result.log, results, REQS)], this_environment(),
                                                 declared=reqs), tmp / "check.html"))
    return [f"run (40 s, 13 requirements): {size(tmp / 'run.html')}, {with_report - plain:.1f} s more than the run alone",
            f"check (the same log):        {size(tmp / 'check.html')}, {check:.1f} s"]


def campaign(results: Path) -> str:
    from tiltload.master.app.campaign.report import report

    _, seconds = timed(lambda: report(results))
    import pyarrow.parquet as pq

    n = pq.read_metadata(results).num_rows
    return f"campaign ({n} runs):          {size(results.parent / 'report.html')}, {seconds:.1f} s (report.md, figures and report.html)"


def falsification(out: Path, fmus: Path) -> str:
    import pandas as pd
    from tiltload.master.app.api.falsifying import report
    from tiltload.master.app.falsify.search import Outcome
    from tiltload.master.app.falsify.spec import load

    spec = load(out / "spec.toml")
    rows = pd.read_parquet(out / "falsification.parquet").to_dict("records")
    negative = [i for i, r in enumerate(rows) if r.get("robustness") is not None and r["robustness"] < 0]
    outcome = Outcome(rows, negative[0] if negative else None, 0.0)
    page, seconds = timed(lambda: report(spec, outcome, out, fmus))
    return f"falsification ({len(rows)} simulations): {size(page)}, {seconds:.1f} s (the best case replayed with a log)"


TESTS = '''
def test_a(tiltload_run):
    assert tiltload_run(controller="dlqr", scenario="fsi", stop_time=10, requirements={reqs!r}).verdicts


def test_b(tiltload_run):
    assert tiltload_run(controller="mixed", scenario="fsi", stop_time=10, requirements={reqs!r}).verdicts
'''


def pytest_session(fmus: Path, tmp: Path) -> str:
    repo = tmp / "repo"
    repo.mkdir()
    (repo / "test_user.py").write_text(TESTS.format(reqs=str(REQS)))
    base = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", f"--tiltload-fmus={fmus}", str(repo)]
    _, plain = timed(lambda: subprocess.run(base, cwd=repo, capture_output=True, check=True))
    _, reported = timed(lambda: subprocess.run([*base, f"--tiltload-report={tmp / 'pytest.html'}"], cwd=repo,
                                               capture_output=True, check=True))
    return f"pytest (2 tests, 10 s runs):  {size(tmp / 'pytest.html')}, {reported - plain:.1f} s more than the session alone"


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    p.add_argument("--campaign", type=Path, required=True, help="a campaign's results.parquet")
    p.add_argument("--falsification", type=Path, required=True, help="a falsification's output folder")
    p.add_argument("--fmus", type=Path, default=ROOT / "fmus")
    a = p.parse_args()
    print(f"report sizes and times on {platform.machine()} {platform.node()}, {time.strftime('%Y-%m-%d %H:%M')}")
    with tempfile.TemporaryDirectory() as tmp:
        for line in [*run_and_check(a.fmus, Path(tmp)), campaign(a.campaign), falsification(a.falsification, a.fmus),
                     pytest_session(a.fmus, Path(tmp))]:
            print("  " + line)


if __name__ == "__main__":
    main()

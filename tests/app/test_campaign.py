"""Campaigns on Dask: specs, expansion, resumable results, a separate scheduler, reports."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pyarrow.parquet as pq
import pytest
from tiltload.master.app.campaign import runner as campaign
from tiltload.master.app.campaign import spec as campaign_spec
from tiltload.master.app.cli import main
from tiltload.master.app.loop import default_system, loop_metrics
from tiltload.master.engine.execution import Execution

SPEC = """
name = "small"
[base]
scenario = "zse"
trajectory = 1
controllers = ["dlqr", "mixed"]
stop_time = 1.5
[vary]
seeds = [1, 2]
[[vary.parameters]]
name = "load_mass"
targets = ["plant.m_L"]
values = [0.05, 0.2, {bad}]
"""


def write_spec(folder: Path, bad: float = 0.3, text: str = SPEC) -> Path:
    path = folder / "small.toml"
    path.write_text(text.replace("{bad}", repr(bad)))
    return path


def rows(path: Path) -> list[dict]:
    return pq.read_table(path).to_pylist()


@pytest.mark.parametrize("text, needle", [
    (SPEC.replace('name = "small"', ""), "small.toml: (top level): 'name' is a required property"),
    (SPEC.replace('scenario = "zse"', 'scenario = "ekf"'), "base.scenario: 'ekf' is not one of"),
    (SPEC.replace("stop_time = 1.5", "stop_time = -1"), "base.stop_time: -1 is less than or equal to the minimum"),
    (SPEC.replace("seeds = [1, 2]", "seeds = [1, 4294967297]"), "vary.seeds.1: 4294967297 is greater than the maximum"),
    (SPEC.replace("[vary]", "[vary]\nsamplez = 3"), "vary: Additional properties are not allowed ('samplez' was unexpected)"),
    (SPEC.replace('targets = ["plant.m_L"]', 'targets = ["m_L"]'), "vary.parameters.0.targets.0: 'm_L' does not match"),
    (SPEC.replace('values = [0.05, 0.2, {bad}]', 'range = [0.05, 0.2]'), "a grid takes values"),
    (SPEC.replace("[vary]", '[vary]\nmethod = "lhs"\nsamples = 4'), "lhs sampling takes range"),
    (SPEC.replace('controllers = ["dlqr", "mixed"]', 'controllers = ["pid"]'), "pid is neither dlqr, mixed nor an existing"),
    ("name = [", "not valid TOML"),
])
def test_a_bad_spec_names_the_field(tmp_path, text, needle):
    with pytest.raises(campaign_spec.SpecError) as err:
        campaign_spec.load(write_spec(tmp_path, text=text))
    assert needle in str(err.value)


def test_a_bad_spec_is_one_line_and_exit_2_from_the_cli(tmp_path, capsys):
    path = write_spec(tmp_path, text=SPEC.replace("stop_time = 1.5", "stop_time = \"long\""))
    assert main(["campaign", str(path)]) == 2
    err = capsys.readouterr().err
    assert "base.stop_time: 'long' is not of type 'number'" in err and err.count("\n") == 1
    assert main(["campaign", str(tmp_path / "none.toml")]) == 2
    assert main(["campaign", "report", str(tmp_path / "none.parquet")]) == 2


def test_grid_and_latin_hypercube_expansion(tmp_path):
    c = campaign_spec.load(write_spec(tmp_path))
    assert len(c.cases) == 3 * 2 * 2 and c.varied == ["load_mass"]
    assert c.cases[0].parameters == {"plant.m_L": 0.05}
    assert [x.run_id for x in campaign_spec.load(write_spec(tmp_path)).cases] == [x.run_id for x in c.cases]  # stable ids
    lhs = SPEC.replace("[vary]", '[vary]\nmethod = "lhs"\nsamples = 8\nsample_seed = 4').replace(
        "values = [0.05, 0.2, {bad}]", "range = [0.02, 0.5]")
    a = campaign_spec.load(write_spec(tmp_path, text=lhs))
    masses = sorted({x.values["load_mass"] for x in a.cases})
    assert len(masses) == 8 and all(0.02 <= m <= 0.5 for m in masses)
    assert sorted(int((m - 0.02) / 0.06) for m in masses) == list(range(8))  # one sample in each of the 8 strata
    assert [x.values for x in campaign_spec.load(write_spec(tmp_path, text=lhs)).cases] == [x.values for x in a.cases]


def test_restart_on_the_same_fmus_equals_a_fresh_instantiation(fmus):
    def metrics_of(execution):
        return {k: v for k, v in execution.observers[0].table().items()}
    system = default_system(fmus, "zse", 1, "mixed", seed=4)
    system.instance("plant").parameters["m_L"] = 0.2
    fresh = Execution(system, [loop_metrics()])
    fresh.instantiate()
    fresh.run(1.5)
    reused = Execution(default_system(fmus, "zse", 1, "dlqr", seed=9), [loop_metrics()])
    reused.instantiate()
    reused.run(0.6)  # a different run first
    reused.restart({i.name: dict(i.parameters) for i in system.instances}, [loop_metrics()])
    reused.run(1.5)
    try:
        assert metrics_of(reused) == metrics_of(fresh)
    finally:
        fresh.close()
        reused.close()


@pytest.fixture(scope="module")
def local_results(fmus, tmp_path_factory):
    folder = tmp_path_factory.mktemp("local")
    results, counts = campaign.run(write_spec(folder, bad=-1.0), folder / "out", workers=2, fmus=fmus, progress=lambda _: None)
    assert {k: counts[k] for k in ("total", "skipped", "ran", "failed")} == {"total": 12, "skipped": 0, "ran": 12, "failed": 4}
    return results


def test_a_failed_run_is_a_row_with_its_error_line(local_results):
    failed = [r for r in rows(local_results) if not r["completed"]]
    assert len(failed) == 4 and all(r["load_mass"] == -1.0 for r in failed)
    assert all("parameter m_L must be positive, got -1" in r["error"] for r in failed)
    ok = [r for r in rows(local_results) if r["completed"]]
    assert all(r["ISE(x)"] > 0 and 0 < r["zse_containment"] <= 1 for r in ok)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_a_separate_scheduler_with_two_workers_gives_identical_rows(fmus, local_results, tmp_path):
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
    procs = [subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", str(port),
                               "--no-dashboard"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)]
    try:
        for _ in range(2):
            procs.append(subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", address, "--nthreads", "1",
                                           "--no-dashboard"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env))
        from dask.distributed import Client

        deadline = time.time() + 60
        while True:
            try:
                with Client(address, timeout="5s") as client:
                    client.wait_for_workers(2, timeout=30)
                break
            except Exception:
                if time.time() > deadline:
                    raise
                time.sleep(0.5)
        results, counts = campaign.run(write_spec(tmp_path, bad=-1.0), tmp_path / "out", scheduler=address, fmus=fmus,
                                       progress=lambda _: None)
    finally:
        for p in procs:
            p.terminate()
        for p in procs:
            p.wait(timeout=30)
    assert counts["ran"] == 12
    assert rows(results) == rows(local_results) or _same_with_nan(rows(results), rows(local_results))


def _same_with_nan(a, b) -> bool:
    import math

    def norm(r):
        return {k: ("nan" if isinstance(v, float) and math.isnan(v) else v) for k, v in r.items()}
    return [norm(r) for r in a] == [norm(r) for r in b]


def test_a_campaign_killed_half_way_finishes_only_the_missing_runs(fmus, local_results, tmp_path):
    spec = write_spec(tmp_path, bad=-1.0)
    out = tmp_path / "out"
    cmd = [sys.executable, "-c", "from tiltload.master.app.cli import entry; entry()", "campaign", str(spec), "--out", str(out),
           "--workers", "1", "--fmus", str(fmus)]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    deadline = time.time() + 120
    while len(list((out / "parts").glob("*.parquet"))) < 2 and time.time() < deadline:
        time.sleep(0.002)  # a run takes tens of ms: kill early, while most of the twelve are still to do
    os.killpg(proc.pid, signal.SIGKILL)  # the campaign and its cluster, at once
    proc.wait()
    done = len(list((out / "parts").glob("*.parquet")))
    assert 2 <= done < 12
    results, counts = campaign.run(spec, out, workers=2, fmus=fmus, progress=lambda _: None)
    assert counts["skipped"] == done and counts["ran"] == 12 - done
    assert _same_with_nan(rows(results), rows(local_results))


def test_the_report_summarizes_and_its_rerun_command_reproduces_a_run(local_results, fmus, tmp_path, capsys):
    assert main(["campaign", "report", str(local_results)]) == 0
    text = (local_results.parent / "report.md").read_text()
    assert "## Per controller" in text and "## Worst runs" in text and (local_results.parent / "distributions.png").is_file()
    assert "error: " in text  # the failed runs come first
    row = next(r for r in rows(local_results) if r["completed"] and r["controller"] == "dlqr" and r["load_mass"] == 0.2)
    from tiltload.master.app.campaign.report import rerun_command
    from tiltload.master.app.campaign.spec import read_spec_file

    command = rerun_command(row, read_spec_file(local_results.parent / "spec.toml")).split()[2:]
    capsys.readouterr()
    assert main(["run", *command, "--fmus", str(fmus), "--no-log", "--quiet"]) == 0
    out = capsys.readouterr().out
    ise_x = float(next(line.split()[1] for line in out.splitlines() if line.strip().startswith("ISE(x)")))
    assert ise_x == pytest.approx(row["ISE(x)"], rel=1e-5)  # the printed table has 6 digits

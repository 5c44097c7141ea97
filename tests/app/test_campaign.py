"""Campaigns on Dask: specs, expansion, resumable results, a separate scheduler, reports."""

from __future__ import annotations

import math
import os
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from dataclasses import asdict, replace
from pathlib import Path

import psutil
import pyarrow.parquet as pq
import pytest
from tiltload.master.app.campaign import runner as campaign
from tiltload.master.app.campaign import spec as campaign_spec
from tiltload.master.app.cli import main
from tiltload.master.app.loop.thesis import default_system, loop_metrics
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
    system.instance("plant").parameters["m_L"] = 1.5
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
    assert {k: counts[k] for k in ("total", "skipped", "ran", "stored", "completed", "failed", "diverged")} == \
        {"total": 12, "skipped": 0, "ran": 12, "stored": 12, "completed": 8, "failed": 4, "diverged": 0}
    return results


@pytest.mark.slow
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


def identical(a: list[dict], b: list[dict]) -> bool:
    """Row for row, bit for bit (NaN equal to NaN)."""
    def norm(r):
        return {k: (v.hex() if isinstance(v, float) else v) for k, v in r.items()}
    return [norm(r) for r in a] == [norm(r) for r in b]


def _can_hide_folders() -> bool:
    """Can a process get a mount namespace of its own (to be a worker that does not see the FMU folder)?"""
    try:
        return subprocess.run(["unshare", "-m", "sh", "-c", "mount -t tmpfs tmpfs /mnt"], capture_output=True,
                              timeout=20).returncode == 0
    except (OSError, subprocess.TimeoutExpired):
        return False


class DaskCluster:
    """A real `dask scheduler` and `dask worker` processes on 127.0.0.1, started and stopped by the test."""

    def __init__(self, port: int | None = None, tls: dict[str, Path] | None = None) -> None:
        self.port = port or _free_port()
        self.address = f"{'tls' if tls else 'tcp'}://127.0.0.1:{self.port}"
        self.env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
        self.tls = ["--tls-ca-file", str(tls["ca"]), "--tls-cert", str(tls["cert"]), "--tls-key", str(tls["key"])] if tls else []
        self.security = None
        if tls:
            from distributed.security import Security

            self.security = Security(tls_ca_file=str(tls["ca"]), tls_client_cert=str(tls["cert"]),
                                     tls_client_key=str(tls["key"]), require_encryption=True)
        self.scheduler: subprocess.Popen | None = None
        self.workers: list[subprocess.Popen] = []

    def start_scheduler(self) -> DaskCluster:
        protocol = ["--protocol", "tls", *self.tls] if self.tls else []
        self.scheduler = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
                                           "--port", str(self.port), "--no-dashboard", *protocol], stdout=subprocess.DEVNULL,
                                          stderr=subprocess.DEVNULL, env=self.env, start_new_session=True)
        deadline = time.time() + 60
        while True:  # until it listens
            try:
                socket.create_connection(("127.0.0.1", self.port), timeout=1).close()
                return self
            except OSError:
                assert self.scheduler.poll() is None and time.time() < deadline, "the scheduler did not start"
                time.sleep(0.1)

    def add_worker(self, hiding: Path | tuple[Path, ...] | None = None, nanny: bool = True, cwd: Path | None = None,
                   cache: Path | None = None) -> subprocess.Popen:
        """A worker (with its nanny); hiding: folders this worker sees empty (a tmpfs over each, its own mounts); cwd:
        the folder it starts in; cache: its machine's tiltload cache ($TILTLOAD_CACHE)."""
        command = [sys.executable, "-m", "distributed.cli.dask_worker", self.address, "--nthreads", "1", "--host",
                   "127.0.0.1", "--no-dashboard", *self.tls, *([] if nanny else ["--no-nanny"])]
        if hiding is not None:
            hidden = [str(h) for h in ((hiding,) if isinstance(hiding, Path) else hiding)]
            mount = 'n=$1; shift; while [ "$n" -gt 0 ]; do mount -t tmpfs tmpfs "$1" || exit 1; shift; n=$((n - 1)); done; exec "$@"'
            command = ["unshare", "-m", "sh", "-c", mount, "sh", str(len(hidden)), *hidden, *command]
        env = {**self.env, "TILTLOAD_CACHE": str(cache)} if cache is not None else self.env
        worker = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env, cwd=cwd,
                                  start_new_session=True)
        self.workers.append(worker)
        return worker

    def wait_for_workers(self, n: int) -> None:
        from dask.distributed import Client

        with Client(self.address, timeout="20s", security=self.security) as client:
            client.wait_for_workers(n, timeout=60)

    def stop(self, process: subprocess.Popen) -> None:
        """At once: the process and what it started (a nanny's worker), its own process group."""
        try:
            os.killpg(process.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        process.wait()

    def stop_all(self) -> None:
        for p in [*self.workers, *([self.scheduler] if self.scheduler else [])]:
            self.stop(p)
        self.workers = []


@pytest.fixture
def dask_cluster():
    clusters = []

    def start(port=None, tls=None) -> DaskCluster:
        clusters.append(DaskCluster(port, tls).start_scheduler())
        return clusters[-1]
    yield start
    for c in clusters:
        c.stop_all()


@pytest.mark.slow
def test_a_separate_scheduler_with_two_workers_gives_identical_rows(fmus, local_results, tmp_path, dask_cluster):
    cluster = dask_cluster()
    cluster.add_worker()
    cluster.add_worker()
    results, counts = campaign.run(write_spec(tmp_path, bad=-1.0), tmp_path / "out", fmus=fmus, progress=lambda _: None,
                                   scheduler=cluster.address, workers=2)
    assert counts["ran"] == 12 and counts["retried"] == 0
    assert identical(rows(results), rows(local_results))


@pytest.mark.slow
def test_a_campaign_killed_half_way_finishes_only_the_missing_runs(fmus, local_results, tmp_path):
    spec = write_spec(tmp_path, bad=-1.0)
    out = tmp_path / "out"
    cmd = [sys.executable, "-c", "from tiltload.master.app.cli import entry; entry()", "campaign", str(spec), "--out", str(out),
           "--workers", "1", "--fmus", str(fmus)]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    deadline = time.time() + 120
    while _stored(out) < 2 and time.time() < deadline:
        time.sleep(0.002)  # a run takes tens of ms: kill early, while most of the twelve are still to do
    os.killpg(proc.pid, signal.SIGKILL)  # the campaign and its cluster, at once
    proc.wait()
    done = _stored(out)
    assert 2 <= done < 12
    results, counts = campaign.run(spec, out, fmus=fmus, progress=lambda _: None, workers=2)
    assert counts["skipped"] == done and counts["ran"] == 12 - done
    assert identical(rows(results), rows(local_results))


def _cli(*args: str) -> list[str]:
    return [sys.executable, "-c", "from tiltload.master.app.cli import entry; entry()", *args]


def _parts(out: Path) -> list[Path]:
    return sorted((out / "parts").glob("*.parquet"))


def _part_rows(out: Path) -> list[dict]:
    """The rows of the parts (a part holds a task's outcomes: one run or several)."""
    return [row for part in _parts(out) for row in rows(part)]


def _stored(out: Path) -> int:
    """How many runs the parts hold."""
    return len({row["run_id"] for row in _part_rows(out)})


@pytest.mark.slow
def test_a_scheduler_killed_mid_campaign_stores_no_cancelled_run_and_the_rerun_finishes_it(fmus, local_results, tmp_path,
                                                                                           dask_cluster, capfd):
    cluster = dask_cluster()
    cluster.add_worker()
    cluster.wait_for_workers(1)
    spec, out = write_spec(tmp_path, bad=-1.0), tmp_path / "out"
    args = ["campaign", str(spec), "--out", str(out), "--fmus", str(fmus), "--scheduler", cluster.address]
    proc = subprocess.Popen(_cli(*args), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=cluster.env)
    deadline = time.time() + 120
    while _stored(out) < 3 and proc.poll() is None and time.time() < deadline:
        time.sleep(0.002)  # a run takes tens of ms: the scheduler goes with most of the twelve still to do
    cluster.scheduler.kill()
    _, stderr = proc.communicate(timeout=60)
    done = _stored(out)
    assert proc.returncode == 1 and 3 <= done < 12
    assert stderr.strip().splitlines()[-1] == (f"tiltload: error: the scheduler at {cluster.address} went away after {done} "
                                               f"of 12 runs; rerun the same command to finish (details: {out / 'campaign.log'})")
    assert "Traceback" not in stderr and "distributed" not in stderr  # Dask's own words are in the log
    log = (out / "campaign.log").read_text()
    # what Dask said is kept there (its words vary with timing: a traceback or only its error line)
    assert f"stopped after {done} of 12 runs" in log and "distributed." in log
    reference = {r["run_id"]: r for r in rows(local_results)}
    for row in _part_rows(out):  # outcomes only, each the undisturbed campaign's: nothing cancelled was stored
        row = {k: v for k, v in row.items() if not k.startswith("_")}
        assert identical([row], [reference[row["run_id"]]])
    for worker in cluster.workers:
        cluster.stop(worker)
    cluster.workers = []
    cluster.start_scheduler()  # the cluster back at the same address, and the same command
    cluster.add_worker()
    cluster.add_worker()
    cluster.wait_for_workers(2)
    capfd.readouterr()
    assert main(args) == 1  # the same command (in this process: a second start of the command is seconds); 4 runs
    # were refused (load_mass -1): a campaign with failed runs exits 1 (docs/exit_codes.md)
    rerun = capfd.readouterr()
    assert f"12 runs, {done} already done, {12 - done} to run" in rerun.err
    assert (f"12 runs: 12 in the results, 8 completed, 4 failed (0 diverged); {done} were done before, {12 - done} ran now"
            in rerun.out)  # each missing run ran once, none of the others again
    assert identical(rows(out / "results.parquet"), rows(local_results))


FOUR = SPEC.replace("values = [0.05, 0.2, {bad}]", "values = [0.05]")  # dlqr and mixed, seeds 1 and 2: 4 runs
FALSIFY = """
name = "shipped"
optimizer = "uniform"
[base]
scenario = "fsi"
trajectory = 1
stop_time = 3.0
gusts = false
[[requirements]]
name = "swing"
formula = "always[1:3] (abs(plant.gamma_1) < 0.2)"
[[search]]
name = "amp"
target = "gust.amplitude"
range = [0.0, 20.0]
[gust]
start = 1.5
duration = 0.8
[budget]
simulations = 4
"""
PER_RUN = ("wall_s", "cpu_s", "worker")  # a falsification row's measures of its own evaluation, and where it ran


@pytest.mark.skipif(not _can_hide_folders(), reason="a worker that does not see the FMU folder needs a mount namespace "
                                                   "(unshare -m)")
@pytest.mark.slow
def test_a_worker_with_no_copy_of_the_fmus_gets_them_by_digest_and_gives_the_local_rows(fmus, tmp_path, dask_cluster):
    """dask scheduler and dask worker started as the docs say, the worker in an empty folder of its own, blind to the FMU
    folder and with a cache of its own: a campaign and a falsification run there as they run locally."""
    from tiltload.master.app.falsify.runner import falsify

    spec = write_spec(tmp_path, text=FOUR)
    local, _ = campaign.run(spec, tmp_path / "local", fmus=fmus, workers=1, progress=lambda _: None)
    searched = tmp_path / "f.toml"
    searched.write_text(FALSIFY)
    falsify(searched, tmp_path / "f-local", fmus=fmus, workers=1, progress=lambda _: None, write_report=False, branch="off")
    cluster = dask_cluster()
    folder, cache = tmp_path / "worker", tmp_path / "worker-cache"
    folder.mkdir()
    cluster.add_worker(hiding=fmus, cwd=folder, cache=cache)  # sees an empty folder at the FMUs' path
    cluster.wait_for_workers(1)
    assert main(["campaign", str(spec), "--out", str(tmp_path / "remote"), "--fmus", str(fmus), "--scheduler",
                 cluster.address]) == 0
    assert identical(rows(tmp_path / "remote" / "results.parquet"), rows(local)) and len(rows(local)) == 4
    falsify(searched, tmp_path / "f-remote", fmus=fmus, scheduler=cluster.address, progress=lambda _: None,
            write_report=False, branch="off")
    a, b = (rows(tmp_path / f / "falsification.parquet") for f in ("f-local", "f-remote"))
    assert len(a) == 4 and identical([{k: v for k, v in r.items() if k not in PER_RUN} for r in a],
                                     [{k: v for k, v in r.items() if k not in PER_RUN} for r in b])
    shipped = list((cache / "shipped").iterdir())  # one set, the files the client has, by content
    assert len(shipped) == 1
    import hashlib

    for path in shipped[0].iterdir():
        assert hashlib.sha256(path.read_bytes()).digest() == hashlib.sha256((fmus / path.name).read_bytes()).digest()
    assert sorted(p.name for p in shipped[0].iterdir()) == sorted(p.name for p in fmus.glob("Tiltload*.fmu"))
    assert any(p.name != "shipped" for p in (cache / "fmus").iterdir())  # unpacked into the worker's machine cache
    assert not list(folder.iterdir()) or all(p.name.startswith("dask-") for p in folder.iterdir())


@pytest.mark.skipif(not _can_hide_folders(), reason="a worker that does not see the FMU folder needs a mount namespace "
                                                   "(unshare -m)")
@pytest.mark.slow
def test_a_users_controller_fmu_reaches_a_worker_that_has_no_copy_of_it(fmus, tmp_path, dask_cluster):
    """A campaign and a search over a user's controller FMU, on an existing cluster whose worker sees neither the FMU
    folder nor the controller's: the controller goes with the shipped set, and the rows are the local run's."""
    import hashlib

    from tiltload.master.app.falsify.runner import falsify

    user = tmp_path / "user"
    user.mkdir()
    shutil.copy(fmus / "TiltloadController.fmu", user / "mine.fmu")  # a copy of ours under another name
    spec = write_spec(tmp_path, text=FOUR.replace('controllers = ["dlqr", "mixed"]', f'controllers = ["{user / "mine.fmu"}"]'))
    searched = tmp_path / "f.toml"
    searched.write_text(FALSIFY.replace('scenario = "fsi"', f'scenario = "fsi"\ncontroller = "{user / "mine.fmu"}"'))
    local, _ = campaign.run(spec, tmp_path / "local", fmus=fmus, workers=1, progress=lambda _: None)
    falsify(searched, tmp_path / "f-local", fmus=fmus, workers=1, progress=lambda _: None, write_report=False, branch="off")
    cluster = dask_cluster()
    folder, cache = tmp_path / "worker", tmp_path / "worker-cache"
    folder.mkdir()
    cluster.add_worker(hiding=(fmus, user), cwd=folder, cache=cache)
    cluster.wait_for_workers(1)
    assert main(["campaign", str(spec), "--out", str(tmp_path / "remote"), "--fmus", str(fmus), "--scheduler",
                 cluster.address]) == 0
    remote = rows(tmp_path / "remote" / "results.parquet")
    assert identical(remote, rows(local)) and len(remote) == 2 and {r["controller"] for r in remote} == {"mine"}
    falsify(searched, tmp_path / "f-remote", fmus=fmus, scheduler=cluster.address, progress=lambda _: None,
            write_report=False, branch="off")
    a, b = (rows(tmp_path / f / "falsification.parquet") for f in ("f-local", "f-remote"))
    assert len(a) == 4 and identical([{k: v for k, v in r.items() if k not in PER_RUN} for r in a],
                                     [{k: v for k, v in r.items() if k not in PER_RUN} for r in b])
    copies = list((cache / "shipped").glob("*/controllers/*/mine.fmu"))
    assert copies and all(hashlib.sha256(c.read_bytes()).digest() == hashlib.sha256((user / "mine.fmu").read_bytes()).digest()
                          for c in copies)


@pytest.mark.parametrize("address, needle", [
    ("garbage", "--scheduler garbage: no port; a Dask scheduler's address is tcp://HOST:PORT"),
    ("", "--scheduler is empty: a Dask scheduler's address is"),
    ("http://127.0.0.1:8787", "http:// is the dashboard's (port 8787 by default)"),
    ("udp://127.0.0.1:8786", "unknown scheme udp://"),
    ("tcp://127.0.0.1:99999", "the port must be a number from 1 to 65535, got '99999'"),
    ("tcp://127.0.0.1:{closed}", "nothing listens at tcp://127.0.0.1:{closed} (connection refused)"),
    ("tcp://127.0.0.1:{silent}", "tcp://127.0.0.1:{silent} accepts connections but does not answer as a Dask scheduler "
                                 "within 1 s"),
    ("tcp://nohost.invalid:8786", "nohost.invalid"),  # unknown, or not resolved within the second
    ("tls://127.0.0.1:{closed}", "tls:// needs Dask's TLS settings"),
])
def test_a_bad_scheduler_address_is_one_line_and_exit_2_in_seconds_before_anything_is_built(tmp_path, capfd, address,
                                                                                            needle):
    closed = _free_port()
    with socket.socket() as silent:  # listens, never answers: like a port that is not a Dask scheduler's
        silent.bind(("127.0.0.1", 0))
        silent.listen(8)
        ports = {"closed": closed, "silent": silent.getsockname()[1]}
        started = time.perf_counter()
        code = main(["campaign", str(write_spec(tmp_path)), "--out", str(tmp_path / "out"), "--fmus", str(tmp_path / "fmus"),
                     "--scheduler", address.format(**ports), "--connect-timeout", "1"])
        seconds = time.perf_counter() - started
    err = capfd.readouterr().err
    assert code == 2 and err.startswith("tiltload: error: ") and err.count("\n") == 1, err
    assert needle.format(**ports) in err
    assert seconds < 10
    assert not (tmp_path / "out").exists() and not (tmp_path / "fmus").exists()  # nothing written, nothing built


@pytest.mark.slow
def test_a_scheduler_without_enough_workers_is_one_line_and_exit_2_in_seconds(tmp_path, dask_cluster, capfd):
    cluster = dask_cluster()
    args = ["campaign", str(write_spec(tmp_path)), "--out", str(tmp_path / "out"), "--fmus", str(tmp_path / "fmus"),
            "--scheduler", cluster.address, "--worker-timeout", "2"]
    started = time.perf_counter()
    assert main(args) == 2
    assert time.perf_counter() - started < 10
    assert capfd.readouterr().err == (f"tiltload: error: the scheduler at {cluster.address} has 0 workers (waited 2 s for "
                                      f"1, --worker-timeout): start them with: dask worker {cluster.address}\n")
    cluster.add_worker()
    cluster.wait_for_workers(1)
    assert main([*args, "--workers", "2"]) == 2  # with --scheduler, --workers is how many to wait for
    assert "has 1 worker (waited 2 s for 2, --worker-timeout)" in capfd.readouterr().err
    from dask.distributed import Client

    with Client(cluster.address, timeout="20s") as client:
        worker = next(iter(client.nthreads()))
    assert main([*args[:-4], "--scheduler", worker]) == 2
    assert f"{worker} is a Dask worker, not the scheduler (its scheduler: {cluster.address})" in capfd.readouterr().err
    assert not (tmp_path / "out").exists() and not (tmp_path / "fmus").exists()


@pytest.mark.slow
def test_the_runs_stop_when_the_last_worker_is_gone_for_good(fmus, local_results, tmp_path, dask_cluster, capfd):
    cluster = dask_cluster()
    worker = cluster.add_worker(nanny=False)  # no nanny to start it again
    cluster.wait_for_workers(1)
    spec, out = write_spec(tmp_path, bad=-1.0), tmp_path / "out"

    def kill_after_two_runs():
        deadline = time.time() + 120
        while _stored(out) < 2 and time.time() < deadline:
            time.sleep(0.002)
        worker.kill()
    killer = threading.Thread(target=kill_after_two_runs)
    killer.start()
    code = main(["campaign", str(spec), "--out", str(out), "--fmus", str(fmus), "--scheduler", cluster.address,
                 "--worker-timeout", "2"])
    killer.join()
    done = _stored(out)
    line = capfd.readouterr().err.strip().splitlines()[-1]
    assert code == 1 and 2 <= done < 12
    assert line.startswith(f"tiltload: error: the scheduler at {cluster.address} has had no workers for 2 s "
                           f"(--worker-timeout) after {done} of 12 runs; start workers and rerun the same command")
    reference = {r["run_id"]: r for r in rows(local_results)}
    for row in _part_rows(out):  # the run the worker took with it is not among them
        row = {k: v for k, v in row.items() if not k.startswith("_")}
        assert identical([row], [reference[row["run_id"]]])


def _certificate(folder: Path) -> dict[str, Path]:
    """A self-signed certificate and its key (made by Dask's Security.temporary), as the files Dask's TLS options take."""
    from distributed.security import Security

    made = Security.temporary()
    folder.mkdir(exist_ok=True)
    files = {"ca": folder / "ca.pem", "cert": folder / "cert.pem", "key": folder / "key.pem"}
    files["ca"].write_text(made.tls_ca_file)
    files["cert"].write_text(made.tls_client_cert)
    files["key"].write_text(made.tls_client_key)
    return files


@pytest.mark.slow
def test_a_tls_cluster_takes_the_campaigns_of_clients_with_its_certificates_only(fmus, local_results, tmp_path, dask_cluster,
                                                                                capfd):
    import dask

    tls = _certificate(tmp_path / "cluster")
    cluster = dask_cluster(tls=tls)
    cluster.add_worker()
    cluster.wait_for_workers(1)
    spec, out = write_spec(tmp_path, bad=-1.0), tmp_path / "out"
    args = ["campaign", str(spec), "--out", str(out), "--fmus", str(fmus), "--connect-timeout", "2"]
    client_tls = {"distributed.comm.tls.ca-file": str(tls["ca"]), "distributed.comm.tls.client.cert": str(tls["cert"]),
                  "distributed.comm.tls.client.key": str(tls["key"])}
    with dask.config.set(client_tls):
        assert main([*args, "--scheduler", cluster.address.replace("tls://", "tcp://")]) == 2
    assert "does not answer as a Dask scheduler within 2 s" in capfd.readouterr().err
    stranger = _certificate(tmp_path / "stranger")  # a certificate the cluster's CA did not sign
    with dask.config.set({**client_tls, "distributed.comm.tls.client.cert": str(stranger["cert"]),
                          "distributed.comm.tls.client.key": str(stranger["key"])}):
        assert main([*args, "--scheduler", cluster.address]) == 2
    err = capfd.readouterr().err
    assert err.count("\n") == 1 and f"the scheduler at {cluster.address} refused the TLS session (SSL" in err
    assert not out.exists()
    env = {**cluster.env, "DASK_DISTRIBUTED__COMM__TLS__CA_FILE": str(tls["ca"]),  # as docs/campaigns.md says
           "DASK_DISTRIBUTED__COMM__TLS__CLIENT__CERT": str(tls["cert"]),
           "DASK_DISTRIBUTED__COMM__TLS__CLIENT__KEY": str(tls["key"])}
    done = subprocess.run(_cli(*args, "--scheduler", cluster.address), capture_output=True, text=True, env=env, timeout=300)
    assert done.returncode == 1 and "4 run(s) failed" in done.stderr, done.stderr  # the refused ones: exit 1
    assert identical(rows(out / "results.parquet"), rows(local_results))


@pytest.mark.slow
def test_nothing_the_campaign_starts_listens_beyond_loopback(fmus, tmp_path):
    proc = subprocess.Popen(_cli("campaign", str(write_spec(tmp_path)), "--out", str(tmp_path / "out"), "--fmus", str(fmus),
                                 "--workers", "2"), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    listening = set()  # (ip, port, pid) of every listening socket of the campaign's process tree, looked at while it runs
    while proc.poll() is None:
        try:
            family = [psutil.Process(proc.pid), *psutil.Process(proc.pid).children(recursive=True)]
        except psutil.NoSuchProcess:
            break
        for p in family:
            try:
                listening |= {(c.laddr.ip, c.laddr.port, p.pid) for c in p.net_connections("inet")
                              if c.status == psutil.CONN_LISTEN}
            except (psutil.NoSuchProcess, psutil.AccessDenied):
                pass
        time.sleep(0.05)
    assert proc.wait() == 0
    # the scheduler, its dashboard and the nannies in the campaign's process, a worker in each of two others
    assert len(listening) >= 6 and len({pid for *_, pid in listening}) >= 3, listening
    assert {ip for ip, *_ in listening} <= {"127.0.0.1", "::1"}, listening


@pytest.mark.slow
def test_retry_failed_reruns_stored_failures_and_the_summary_counts_what_the_results_hold(fmus, local_results, tmp_path,
                                                                                          capsys):
    out = tmp_path / "out"
    shutil.copytree(local_results.parent / "parts", out / "parts")
    for row in [r for r in rows(local_results) if r["completed"]][:2]:  # as an older tiltload stored lost futures
        false_failure = {k: row[k] for k in ("run_id", "controller", "seed", "load_mass")}
        false_failure.update(completed=False, diverged=False, diverged_at=math.nan,
                             error="worker lost: FutureCancelledError: cancelled for reason: scheduler-connection-lost.")
        campaign.write_part(out / "parts", {"row": false_failure, "wall": 0.0, "setup": 0.0, "sim_time": 0.0})
    args = ["campaign", str(write_spec(tmp_path, bad=-1.0)), "--out", str(out), "--fmus", str(fmus), "--workers", "1"]
    assert main(args) == 1  # failed runs in the results: exit 1 (docs/exit_codes.md)
    assert "12 runs: 12 in the results, 6 completed, 6 failed (0 diverged); 12 were done before, 0 ran now" in \
        capsys.readouterr().out
    assert main([*args, "--retry-failed"]) == 1  # the 4 refused ones fail again
    assert "12 runs: 12 in the results, 8 completed, 4 failed (0 diverged); 6 were done before, 6 ran now" in \
        capsys.readouterr().out
    assert identical(rows(out / "results.parquet"), rows(local_results))


def test_a_missing_fmu_is_the_environment_s_failure_and_a_refused_value_the_run_s(fmus, tmp_path):
    from tiltload.master.app.campaign.run_case import run_case

    c = campaign_spec.load(write_spec(tmp_path, bad=-1.0))
    refused = next(x for x in c.cases if x.values["load_mass"] == -1.0)
    outcome = run_case(c.base(), asdict(refused), str(fmus), None)
    assert outcome["row"]["completed"] is False and "parameter m_L must be positive, got -1" in outcome["row"]["error"]
    elsewhere = tmp_path / "elsewhere"
    lost = run_case(c.base(), asdict(c.cases[0]), str(elsewhere), None)
    assert "row" not in lost and f"no FMU at {elsewhere}/" in lost["environment"]
    blocked = tmp_path / "a-file"
    blocked.write_text("")
    unwritable = run_case(c.base(), asdict(c.cases[0]), str(fmus), str(blocked / "logs"))  # the log folder cannot exist
    assert "row" not in unwritable and "Error" in unwritable["environment"]


@pytest.mark.slow
def test_the_report_summarizes_and_its_rerun_command_reproduces_a_run(local_results, fmus, tmp_path, capsys):
    assert main(["campaign-report", str(local_results)]) == 0
    text = (local_results.parent / "report.md").read_text()
    assert "## Per controller" in text and "## Worst runs" in text and (local_results.parent / "distributions.png").is_file()
    assert "error: " in text  # the failed runs come first
    row = next(r for r in rows(local_results) if r["completed"] and r["controller"] == "dlqr" and r["load_mass"] == 0.2)
    from tiltload.master.app.campaign.report import rerun_command
    from tiltload.master.app.case.spec_file import read_spec_file

    command = rerun_command(row, read_spec_file(local_results.parent / "spec.toml")).split()[2:]
    capsys.readouterr()
    assert main(["run", *command, "--fmus", str(fmus), "--no-log", "--quiet"]) == 0
    out = capsys.readouterr().out
    ise_x = float(next(line.split()[1] for line in out.splitlines() if line.strip().startswith("ISE(x)")))
    assert ise_x == pytest.approx(row["ISE(x)"], rel=1e-5)  # the printed table has 6 digits


def test_the_html_report_counts_what_the_results_hold(local_results):
    import json
    import re

    assert main(["campaign-report", str(local_results)]) == 0
    page = (local_results.parent / "report.html").read_text(encoding="utf-8")
    data = json.loads(re.search(r'id="tiltload-results">(.*?)</script>', page, re.S).group(1).replace("<\\/", "</"))
    stored = rows(local_results)
    failed = [r for r in stored if r["error"] or not r["completed"]]
    assert len(data["tests"]) == len(stored) and failed
    assert data["counts"]["ERROR"] == len(failed)  # no keep.requirements here: a failed run is one ERROR
    assert 'src="data:image/png;base64,' in page  # the distributions inline
    commands = {t["command"] for t in data["tests"]}
    assert all(c.startswith("tiltload run ") for c in commands) and len(commands) == len(stored)


BRANCHES = """
name = "branches"
[base]
snapshot = "at.snapshot"
stop_time = 3.0
faults = [{{action = "scale", target = "plant.f_L", value = 1.0, start = 2.0}}]
[vary]
seeds = [{seeds}]
[[vary.parameters]]
name = "thrust_left"
targets = ["faults.0.value"]
values = [1.0, 0.8]
"""


def _log_metrics(path: Path) -> dict[str, float]:
    from tiltload.master.engine.log.reader import read_metadata

    return {k: float(v) for k, v in read_metadata(path)["metrics"].items() if k.startswith(("ISE", "IADU"))}


@pytest.mark.slow
def test_fifty_branches_from_one_snapshot_each_cover_the_rest_of_the_run(fmus, tmp_path, capsys):
    """A ZSE run snapshotted at 1.5 s; 50 branches (25 sensor seeds x a left rotor at 100 % or 80 % from 2 s) run on
    Dask from it. Independent fact: the branch that changes nothing (the run's own seed, the fault at 100 %) has the
    metrics of the uninterrupted 3 s run minus those of its first 1.5 s; the others differ from it."""
    common = ["--fmus", str(fmus), "--out", str(tmp_path), "--quiet", "--no-plots", "--scenario", "zse", "--controller",
              "dlqr", "--seed", "1"]
    assert main(["run", "--stop-time", "3", "--snapshot-at", "1.5", str(tmp_path / "at.snapshot"), "--name", "whole",
                 *common]) == 0
    assert main(["run", "--stop-time", "1.5", "--name", "prefix", *common]) == 0
    spec = tmp_path / "branches.toml"
    spec.write_text(BRANCHES.format(seeds=", ".join(map(str, range(1, 26)))))
    results, counts = campaign.run(spec, tmp_path / "out", workers=2, fmus=fmus, progress=lambda _: None)
    assert (counts["total"], counts["completed"], counts["failed"]) == (50, 50, 0)
    table = rows(results)
    whole, prefix = _log_metrics(tmp_path / "whole.mcap"), _log_metrics(tmp_path / "prefix.mcap")
    unchanged = next(r for r in table if r["seed"] == 1 and r["thrust_left"] == 1.0)
    for key in whole:
        assert unchanged[key] == pytest.approx(whole[key] - prefix[key], rel=1e-9, abs=1e-12), key
    ise = [r["ISE(x)"] for r in table]
    assert len(set(ise)) == 50  # every seed and every thrust gives its own branch
    weak = {r["seed"]: r for r in table if r["thrust_left"] == 0.8}
    assert all(weak[s]["ISE(x)"] != r["ISE(x)"] for s, r in ((r["seed"], r) for r in table if r["thrust_left"] == 1.0))


@pytest.mark.parametrize("edit, needle", [
    (lambda s: s.replace("stop_time = 3.0", "stop_time = 3.0\ntrajectory = 2"),
     "base.trajectory: a campaign from a snapshot runs the snapshot's loop"),
    (lambda s: s.replace('targets = ["faults.0.value"]', 'targets = ["plant.m_L"]'),
     "plant.m_L is a fixed parameter: only tunable parameters can change"),
    (lambda s: s.replace("stop_time = 3.0", "stop_time = 1.0"), "base.stop_time: 1.0 s is not after the snapshot's time"),
    (lambda s: s.replace("at.snapshot", "missing.snapshot"), "missing.snapshot: no such file"),
])
def test_a_bad_branching_spec_is_one_line_before_any_run(fmus, tmp_path, capfd, edit, needle):
    common = ["--fmus", str(fmus), "--out", str(tmp_path), "--quiet", "--no-plots", "--scenario", "fsi", "--controller",
              "dlqr"]
    assert main(["run", "--stop-time", "2", "--snapshot-at", "1.5", str(tmp_path / "at.snapshot"), "--no-log", *common]) == 0
    capfd.readouterr()
    spec = tmp_path / "branches.toml"
    spec.write_text(edit(BRANCHES.format(seeds="1, 2")))
    assert main(["campaign", str(spec), "--out", str(tmp_path / "out"), "--fmus", str(fmus), "--workers", "1"]) == 2
    err = capfd.readouterr().err
    assert "Traceback" not in err and err.strip().splitlines()[-1].startswith("tiltload: error: "), err
    assert needle in err.strip().splitlines()[-1], err
    assert not (tmp_path / "out" / "parts").exists() or not list((tmp_path / "out" / "parts").iterdir())


def test_the_client_s_feasibility_verdicts_are_the_check_s_and_a_worker_uses_them(fmus, tmp_path):
    from tiltload.master.app.batch.worker import CaseWorker, checked_plant, feasibility_verdicts
    from tiltload.master.app.campaign.run_case import run_case
    from tiltload.master.app.case.flight import flight_of
    from tiltload.master.app.case.system import case_system
    from tiltload.master.app.feasibility.policy import check_system

    c = campaign_spec.load(write_spec(tmp_path))
    base, cases = c.base(), [asdict(x) for x in c.cases]
    verdicts = feasibility_verdicts(base, cases, str(fmus))
    assert len(verdicts) == 3  # one a load mass: the plant's parameters are the key, not the seed or the controller
    flight = flight_of(base)
    for case in cases[:: len(cases) // 3]:  # the check itself, on the case's own system
        system = case_system(fmus, base, case["controller"], case["seed"], case["parameters"])
        report = check_system(system, base.stop_time, flight.max_tilt)
        key = (flight, checked_plant(system.instance("plant").parameters), base.stop_time)
        assert verdicts[key] == (report.problems[0] if report is not None and report.problems else None)
    planted = {key: "planted by the client" for key in verdicts}  # a worker takes the client's word, not its own check
    outcome = run_case(replace(base, feasibility=planted), cases[0], str(fmus), None, worker=CaseWorker(keep=False))
    assert outcome["row"]["error"] == "the reference is infeasible: planted by the client"


def test_campaign_metrics_equal_a_step_by_step_count(fmus):
    """CampaignMetrics (vectorized over the tick loop's batches, their index arrays kept per record layout) against
    the same definitions counted step by step in Python: the plant's and the reference's latest values before each
    controller step, the command it gave (the replay of each batch starts from the values the last one ended with:
    before, an instance not yet stepped in a batch showed its values at the batch's end). Twice on one pool (the
    second run reads the layouts the first made), in batches of 7 ticks, with a 1.5 kg load so that the thrusts
    saturate, the ZSE's bounds checked at every step."""
    from tiltload.master.app.campaign.metrics import CampaignMetrics
    from tiltload.master.app.loop.thesis import COMMANDS, CONTROLLER, PLANT, SCENARIO, TRACKED
    from tiltload.master.engine.lifecycle import ExecutionPool, RunPlan, run_plan
    from tiltload.master.engine.observers import Observer, real_outputs

    class StepByStep(Observer):
        def start(self, execution):
            self.ins = execution.instances
            self.steps = []  # (t, plant values, reference values, controller values) at each controller step

        def on_step(self, instance, t):
            if instance.name == CONTROLLER and t < 3.0 - 1e-9:  # not the closing sample at 3 s: it starts no tick
                self.steps.append((t, *(self.ins[n].values["Real"].copy() for n in (PLANT, SCENARIO, CONTROLLER))))

    system = default_system(fmus, "zse", 1, "mixed", seed=3)
    system.instance("plant").parameters["m_L"] = 1.5
    pool = ExecutionPool()
    try:
        for _ in range(2):
            metrics, steps = CampaignMetrics(settle=1.0), StepByStep()
            run_plan(RunPlan(system, 3.0, observers=(metrics, steps), segment=7), pool)
            p_out, r_out, c_out = (real_outputs(steps.ins[n]) for n in (PLANT, SCENARIO, CONTROLLER))
            ise, iadu, worst, saturated, contained, previous = [0.0] * len(TRACKED), [0.0] * 4, 0.0, 0, 0, None
            for t, p, r, c in steps.steps:
                e = [p[p_out[a]] - r[r_out[b]] for a, b in TRACKED]
                u = [c[c_out[n]] for n in COMMANDS]
                ise = [s + x * x * system.tick for s, x in zip(ise, e)]
                if previous is not None:
                    iadu = [s + abs(a - b) for s, a, b in zip(iadu, u, previous)]
                previous = u
                if t >= 1.0:
                    worst = max(worst, math.sqrt(e[0] ** 2 + e[1] ** 2 + e[2] ** 2))
                saturated += any(f <= 1e-9 or f >= 30 - 1e-9 for f in u[:2]) or any(abs(x) >= 2 - 1e-9 for x in u[2:])
                names = [v.name for v in steps.ins[PLANT].outputs["Real"]][:20]
                contained += all(c[c_out[f"est_{n}_lo"]] <= p[i] <= c[c_out[f"est_{n}_hi"]] for i, n in enumerate(names))
            row = metrics.row(("ISE", "IADU", "max_tracking_error", "time_saturated", "zse_containment"))
            assert [row[f"ISE({a})"] for a, _ in TRACKED] == pytest.approx(ise, rel=1e-12, abs=1e-300)
            assert [row[f"IADU({n})"] for n in COMMANDS] == pytest.approx(iadu, rel=1e-12)
            assert row["max_tracking_error"] == pytest.approx(worst, rel=1e-12)
            assert row["time_saturated"] == saturated / len(steps.steps) and saturated > 0
            assert row["zse_containment"] == contained / len(steps.steps) and 0 < contained
    finally:
        pool.close()


def test_campaign_metrics_do_not_depend_on_the_batching_of_a_diverging_run(fmus):
    """A 6 kg load makes the plant diverge at 1.512 s: the row is the same, bit for bit, whether the loop ran in one
    call, in calls of 7 ticks (the failed call then holds no plant record, which the numpy form lost) or of 50."""
    from tiltload.master.app.campaign.metrics import CampaignMetrics
    from tiltload.master.engine.lifecycle import ExecutionPool, RunPlan, run_plan

    keep = ("ISE", "IADU", "max_tracking_error", "time_saturated", "zse_containment")
    rows, errors = [], []
    pool = ExecutionPool()
    try:
        for segment in (None, 7, 50):
            system = default_system(fmus, "fsi", 1, "dlqr", seed=1)
            system.instance("plant").parameters["m_L"] = 6.0
            metrics = CampaignMetrics(bounds=False, settle=1.0)
            result = run_plan(RunPlan(system, 4.0, observers=(metrics,), segment=segment, outcomes=(Exception,),
                                      when=False), pool)
            rows.append({k: float(v).hex() for k, v in metrics.row(keep).items()})
            errors.append(result.error)
    finally:
        pool.close()
    assert all(e is not None and "diverged" in e for e in errors), errors
    assert rows[0] == rows[1] == rows[2]
    assert math.isfinite(float.fromhex(rows[0]["ISE(x)"])) and metrics.controller_steps == 127

"""The thesis loop on the FMI 3.0 FMUs: the twelve reproduction cases, plain and with clocks, give the FMI 2.0 metrics
bit for bit (and so the committed baselines, within their tolerances); `tiltload run --fmi 3 [--clocks]` and its
refusals; a clocked controller whose Event Mode fails ends the run with one line, stepped by the C loop or hosted."""

from __future__ import annotations

import os
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context

import pytest
from support import ROOT
from support.fmi3_misbehaving import misbehaving_fmi3
from support.loop_runs import case_metrics
from tiltload.master.app.cli import main
from tiltload.master.app.regression import compare as cmp
from tiltload.master.app.regression.reproduce import BASELINE_RTOL, CASES, case_name


@pytest.fixture(scope="module")
def fmi3_set(fmi3_fmus):
    from tiltload.master.app.loop.fmus import build_all

    folder = fmi3_fmus["TiltloadPlant"].parent
    build_all(folder, progress=lambda *_: None, fmi_version=3, clocked=True)
    return folder


@pytest.mark.slow
def test_twelve_cases_on_plain_and_clocked_fmi3_fmus_equal_the_fmi2_runs_bit_for_bit(fmus, fmi3_set):
    """The clocked FMUs stepped by the C loop's own Event Mode (native/clocks.py), the plain ones by its fmi3 calls."""
    os.environ["OPENBLAS_NUM_THREADS"] = "1"
    with ProcessPoolExecutor(max_workers=2, mp_context=get_context("spawn")) as pool:
        fmi2 = [pool.submit(case_metrics, str(fmus), *case) for case in CASES]
        plain = [pool.submit(case_metrics, str(fmi3_set), *case, 3, False) for case in CASES]
        clocked = [pool.submit(case_metrics, str(fmi3_set), *case, 3, True) for case in CASES]
        results = [(case, a.result(), b.result(), c.result()) for case, a, b, c in zip(CASES, fmi2, plain, clocked)]
    for case, two, three, with_clocks in results:
        assert three == two and with_clocks == two, case_name(*case)  # float ==: the same bits
        base, tolerances = cmp.load_metrics(ROOT / "baselines" / f"{case_name(*case)}.json")
        passed, rows = cmp.compare(two, base, BASELINE_RTOL, 1e-12, tolerances)
        assert passed, cmp.format_rows(rows)


def test_the_uav_alone_on_clocked_fmi3_fmus_equals_fmi2_bit_for_bit(fmus, fmi3_set):
    """Appendix A's loop (the UAV without the load, its own sensor suite of Table A.1 and controller)."""
    from tiltload.master.app.loop.fmus import build_all
    from tiltload.master.app.loop.thesis import default_system, loop_metrics
    from tiltload.master.engine.run import run_system

    build_all(fmus, progress=lambda *_: None, vehicles=("uav",))
    build_all(fmi3_set, progress=lambda *_: None, vehicles=("uav",), fmi_version=3, clocked=True)
    runs = [run_system(default_system(folder, "zse", 3, "dlqr", vehicle="uav", **kw), 3.0, None, loop_metrics(), progress=False)
            for folder, kw in ((fmus, {}), (fmi3_set, {"fmi": 3, "clocked": True}))]
    assert all(r.error is None for r in runs) and runs[0].metrics == runs[1].metrics


def test_run_fmi3_with_clocks_reports_its_metrics_and_log(fmi3_set, tmp_path, capsys):
    fmus = fmi3_set.parent
    args = ["run", "--stop-time", "2", "--fmus", str(fmus), "--out", str(tmp_path), "--quiet", "--no-plots"]
    assert main([*args, "--fmi", "3", "--clocks"]) == 0
    clocked = capsys.readouterr().out
    assert f"log: {tmp_path / 'zse_traj1_mixed_seed1_fmi3_clocks_t2s.mcap'}" in clocked
    assert main(args) == 0  # the same run on the FMI 2.0 FMUs: the same metrics
    fmi2 = capsys.readouterr().out
    table = lambda out: [ln for ln in out.splitlines() if ln.strip().startswith(("ISE", "IADU"))]  # noqa: E731
    assert table(clocked) == table(fmi2) and len(table(fmi2)) == 8


@pytest.mark.slow
def test_a_clocked_fmi3_run_continued_from_its_snapshot_ends_as_the_whole_run(fmi3_set, tmp_path, capsys):
    """tiltload run --fmi 3 --clocks --snapshot-at 2, then --from-snapshot (which takes --fmi 3 --clocks from the
    snapshot): the metrics of 4 s, as the uninterrupted run prints them."""
    fmus = fmi3_set.parent
    common = ["--fmus", str(fmus), "--quiet", "--no-plots", "--no-log"]
    snap = tmp_path / "at2.snapshot"
    assert main(["run", "--fmi", "3", "--clocks", "--stop-time", "4", "--snapshot-at", "2", str(snap), *common]) == 0
    whole = capsys.readouterr().out
    assert main(["run", "--from-snapshot", str(snap), "--stop-time", "4", *common]) == 0
    continued = capsys.readouterr().out
    table = lambda out: [ln for ln in out.splitlines() if ln.strip().startswith(("ISE", "IADU"))]  # noqa: E731
    assert "continuing from" in continued and len(table(whole)) == 8 and table(continued) == table(whole)


@pytest.mark.parametrize("args, needle", [
    (["run", "--clocks"], "--clocks: clocks are FMI 3.0's; add --fmi 3"),
    (["run", "--fmi", "3", "--system", "loop.json"], "--fmi applies to the thesis's loop only"),
    (["run", "--from-snapshot", "s.snapshot", "--fmi", "3"], "--from-snapshot: --fmi cannot change in a continued run"),
    (["reproduce", "--clocks"], "--clocks: clocks are FMI 3.0's; add --fmi 3"),
])
def test_fmi_options_refuse_what_does_not_fit_in_one_line(tmp_path, capsys, args, needle):
    (tmp_path / "loop.json").write_text("{}")
    old = os.getcwd()
    os.chdir(tmp_path)
    try:
        assert main(args) == 2
    finally:
        os.chdir(old)
    err = capsys.readouterr().err
    assert needle in err and "Traceback" not in err and len(err.strip().splitlines()) == 1


def test_fmi_version_must_be_2_or_3(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["run", "--fmi", "4"])
    assert exit_.value.code == 2 and "invalid choice: 4" in capsys.readouterr().err


EVENT_MODE_FAILURES = {  # fmi3UpdateDiscreteStates of the clocked controller from t = 0.5 s: what the one line says
    "update_error": "controller: updateDiscreteStates at t=0.504 s failed (error)",
    "unsettled": "controller: its discrete states still needed an update after 100 iterations at t=0.504 s",
}


@pytest.fixture(scope="module")
def failing_events(fmi3_set, tmp_path_factory):
    """Our clocked controller, foreign, its fmi3UpdateDiscreteStates failing from t = 0.5 s (support/fmi3_misbehaving.py)."""
    return misbehaving_fmi3(fmi3_set / "TiltloadControllerClocked.fmu", tmp_path_factory.mktemp("events"), EVENT_MODE_FAILURES, 0.5)


@pytest.mark.parametrize("where", ["kernel", "link", "pipe"])
@pytest.mark.parametrize("mode", list(EVENT_MODE_FAILURES))
def test_a_clocked_controller_whose_event_mode_fails_ends_the_run_with_one_line(mode, where, failing_events, fmi3_set,
                                                                                  tmp_path, capsys, monkeypatch):
    """--trust-fmus: in this process, its Event Mode run by the C loop; else (a foreign FMU) in a worker process, run
    there by the kernel's sequence on the shared-memory link, or by the slave's Python sequence on its pipe. The same
    line each way, and the log readable up to the failure."""
    from tiltload.master.engine.isolation import hosting

    monkeypatch.setattr(hosting, "SHARED_MEMORY", where != "pipe")
    fmus = fmi3_set.parent
    trust = ["--trust-fmus"] if where == "kernel" else []
    code = main(["run", "--scenario", "fsi", "--fmi", "3", "--clocks", "--fmus", str(fmus), "--out", str(tmp_path), "--no-plots",
                 "--quiet", "--name", mode, "--controller", str(failing_events[mode]), "--stop-time", "2", *trust])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1 and len(err) == 1 and "Traceback" not in err[0], err
    assert err[0].startswith(f"tiltload: error: {EVENT_MODE_FAILURES[mode]}"), err
    assert err[0].endswith("the log is readable up to t = 0.504 s"), err

"""The thesis's closed loop through the FMUs: stable, tracking, deterministic; third-party controllers through the port contract."""

from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np
import pytest
from scipy.linalg import solve_discrete_are
from support.third_party_controller import build as build_third_party
from support.third_party_controller import user_controller
from tiltload.master.app.cli import main
from tiltload.master.app.loop.thesis import default_system, loop_metrics
from tiltload.master.engine.log import reader as log_reader
from tiltload.master.engine.observers import Observer
from tiltload.master.engine.run import run_system
from tiltload.plant_fmu.interface import STATE_NAMES

THESIS_ISE_TRAJ1 = {  # Tables 5.4 (FSI), 5.6 (LKF), 5.9 (ZSE): (DLQR, mixed) for x, y, z
    "fsi": {"dlqr": (0.1571, 0.1111, 0.0428), "mixed": (0.1521, 0.1167, 0.0385)},
    "lkf": {"dlqr": (0.1624, 0.1196, 0.0493), "mixed": (0.1700, 0.1385, 0.0380)},
    "zse": {"dlqr": (0.4146, 0.2895, 0.1389), "mixed": (0.2580, 0.1801, 0.1326)},
}


def short_run(fmus, tmp_path, name, stop=1.2, **kw):
    system = default_system(fmus, **kw)
    return run_system(system, stop, tmp_path / f"{name}.mcap", loop_metrics(), progress=False)


@pytest.mark.parametrize("scenario", ["fsi", "lkf", "zse"])
@pytest.mark.parametrize("controller", ["dlqr", "mixed"])
@pytest.mark.slow
def test_thesis_loop_trajectory_1_is_stable_and_tracks(fmus, tmp_path, scenario, controller):
    """40 s of trajectory 1 through the four FMUs: stable, gusts rejected, ISE of the order of the thesis's tables."""
    res = short_run(fmus, tmp_path, f"{scenario}_{controller}", stop=40.0, scenario=scenario, controller=controller)
    assert res.error is None and res.ticks == 3334  # 40 s is 3333.33 ticks: the run ends at the first tick after it
    plant = log_reader.read(res.log, topics=["/plant", "/scenario"])
    last = plant["/plant"][-400:]  # the last 4.8 s, after every gust has developed
    ref = {m["t"]: m for m in plant["/scenario"]}
    err = [max(abs(m[a] - ref[round(m["t"] - 0.012, 9)][f"{a}_ref"]) for a in "xyz") for m in last
           if round(m["t"] - 0.012, 9) in ref]
    assert max(err) < 0.4  # still on the path with all three gusts acting
    for i, axis in enumerate("xyz"):
        thesis = THESIS_ISE_TRAJ1[scenario][controller][i]
        assert thesis / 5 < res.metrics[f"ISE({axis})"] < thesis * 5, (axis, res.metrics[f"ISE({axis})"], thesis)


def test_zse_bounds_show_the_gps_and_camera_teeth(fmus, tmp_path):
    res = short_run(fmus, tmp_path, "teeth", stop=3.0, scenario="zse")
    ctrl = log_reader.read(res.log, topics=["/controller"])["/controller"][150:]
    wx = np.array([m["est_x_hi"] - m["est_x_lo"] for m in ctrl])
    k = np.round(np.array([m["t"] for m in ctrl]) / 0.012).astype(int)
    drops = np.diff(wx) < 0
    assert np.all(drops[(k[1:] % 10) == 0])  # the x bound narrows at each GPS tick ...
    assert not np.any(drops[(k[1:] % 10) == 5])  # ... and grows half-way between (no GPS, no camera gain on x)
    wdx = np.array([m["est_alpha_R_hi"] - m["est_alpha_R_lo"] for m in ctrl])
    assert wdx.std() > 0


@pytest.mark.slow
def test_same_seed_same_metrics_bit_for_bit(fmus, tmp_path):
    a = short_run(fmus, tmp_path, "a", seed=5)
    b = short_run(fmus, tmp_path, "b", seed=5)
    c = short_run(fmus, tmp_path, "c", seed=6)
    assert a.metrics == b.metrics and a.metrics != c.metrics


def lqr_for_third_party():
    from tiltload.controller_fmu.design.estimator_setup import augmented_model

    m = augmented_model()
    A, B = m.A[:20, :20], m.B[:20]
    P = solve_discrete_are(A, B, np.diag([50.0] * 3 + [1.0] * 17), np.eye(4))
    return np.linalg.solve(B.T @ P @ B + np.eye(4), B.T @ P @ A), m.trim


@pytest.fixture(scope="module")
def third_party(tmp_path_factory):
    K, trim = lqr_for_third_party()
    folder = tmp_path_factory.mktemp("third_party")
    fmus = {mode: Path(build_third_party(folder, K, trim.x, trim.u, STATE_NAMES, mode)) for mode in ("missing", "int")}
    for mode in ("ok", "nan"):  # the way a user makes one: tiltload wrap
        source = user_controller(folder, K, trim.x, trim.u, STATE_NAMES, mode)
        assert main(["wrap", str(source), "--out", str(folder / f"wrapped_{mode}.fmu")]) == 0
        fmus[mode] = folder / f"wrapped_{mode}.fmu"
    return fmus


@pytest.mark.slow
def test_third_party_controller_runs_through_the_cli(fmus, third_party, tmp_path, capsys):
    code = main(["run", "--controller", str(third_party["ok"]), "--scenario", "fsi", "--trajectory", "0",
                 "--stop-time", "3", "--fmus", str(fmus), "--out", str(tmp_path), "--quiet", "--no-plots", "--no-gusts"])
    out = capsys.readouterr().out
    assert code == 0, out
    plant = log_reader.read(next(tmp_path.glob("*.mcap")), topics=["/plant"])["/plant"]
    assert max(abs(m["z"]) for m in plant[-50:]) < 0.05  # it hovers the load at the origin


@pytest.mark.parametrize("mode, needle", [("missing", "missing required output 'tau_L'"), ("int", "'tau_L' must be Real")])
def test_controller_missing_a_port_is_refused_before_stepping(fmus, third_party, tmp_path, capsys, mode, needle):
    code = main(["run", "--controller", str(third_party[mode]), "--fmus", str(fmus), "--out", str(tmp_path), "--quiet"])
    err = capsys.readouterr().err
    assert code == 2 and needle in err and "Traceback" not in err
    assert not list(tmp_path.glob("*.mcap"))  # refused before anything ran


def test_nan_mid_run_stops_with_one_line_and_a_readable_log(fmus, third_party, tmp_path, capsys):
    code = main(["run", "--controller", str(third_party["nan"]), "--scenario", "fsi", "--trajectory", "0", "--stop-time", "3",
                 "--fmus", str(fmus), "--out", str(tmp_path), "--quiet", "--no-plots"])
    err = capsys.readouterr().err
    # the wrapped controller refuses to output it, naming the class and the time
    assert code == 1 and "controller: doStep at t=1.008 s" in err and "ThirdPartyLQR.step returned a non-finite command" in err
    assert "Traceback" not in err
    plant = log_reader.read(next(tmp_path.glob("*.mcap")), topics=["/plant"])["/plant"]
    assert 1.0 <= plant[-1]["t"] <= 1.008 + 1e-9  # everything up to the failed step (NaN from t = 1.008 s) is there
    assert "error" in log_reader.read_metadata(next(tmp_path.glob("*.mcap")))


class Interrupt(Observer):
    def on_tick(self, k, t):
        if k == 50:
            raise KeyboardInterrupt


def test_ctrl_c_finalizes_the_log(fmus, tmp_path):
    """An interrupt in the middle (raised by an observer at tick 50) leaves a finalized, readable log."""
    log = tmp_path / "cut.mcap"
    res = run_system(default_system(fmus, "fsi", 1), 5.0, log, observers_extra=[Interrupt()], progress=False)
    assert res.error == "interrupted by SIGINT at t = 0.600 s" and res.signal == 2
    msgs = log_reader.read(log, topics=["/plant"])["/plant"]
    assert len(msgs) == 51 and abs(msgs[-1]["t"] - 0.6) < 1e-9
    assert log_reader.read_metadata(log)["error"]["message"] == res.error


@pytest.mark.parametrize("delay, lag", [(False, 1), (True, 2)])
def test_delay_option_shifts_the_actuation_by_one_tick(fmus, tmp_path, delay, lag):
    """The plant's applied input over [t_k, t_k+1) is u_k, or u_(k-1) with --delay."""
    res = short_run(fmus, tmp_path, f"delay{delay}", stop=0.6, scenario="fsi", delay=delay)
    data = log_reader.read(res.log, topics=["/plant", "/controller"])
    u = {round(m["t"] / 0.012): m["f_R"] for m in data["/controller"][1:]}
    applied = {round(m["t"] / 0.012): m["f_R_applied"] for m in data["/plant"][1:]}
    pairs = [(applied[k], u[k - lag]) for k in applied if k - lag in u]
    assert len(pairs) > 40 and all(a == b for a, b in pairs)


def _edited(fmu: Path, out: Path, *replacements: tuple[str, str]) -> Path:
    """A copy of an FMU with its modelDescription.xml edited (names and the default experiment only)."""
    with zipfile.ZipFile(fmu) as src, zipfile.ZipFile(out, "w") as dst:
        for item in src.infolist():
            data = src.read(item)
            if item.filename == "modelDescription.xml":
                text = data.decode()
                for old, new in replacements:
                    assert old in text
                    text = text.replace(old, new)
                data = text.encode()
            dst.writestr(item, data)
    return out


@pytest.mark.slow
def test_a_controller_input_the_contract_does_not_know_is_refused_unless_allowed(fmus, third_party, tmp_path, capsys):
    misspelt = _edited(third_party["ok"], tmp_path / "misspelt.fmu", ('name="x_ref"', 'name="ref_x"'))
    args = ["run", "--controller", str(misspelt), "--scenario", "fsi", "--trajectory", "0", "--stop-time", "0.6", "--fmus", str(fmus),
            "--out", str(tmp_path), "--quiet", "--no-plots", "--no-gusts"]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "input 'ref_x' is not a port of the contract (did you mean 'x_ref'?)" in err and err.count("\n") == 1
    assert main([*args, "--allow-unknown-inputs"]) == 0


@pytest.mark.parametrize("step, ok", [("0.024", True), ("0.02", False)])
def test_a_controller_runs_at_its_declared_step_size(fmus, third_party, tmp_path, capsys, step, ok):
    slow = _edited(third_party["ok"], tmp_path / f"slow{step}.fmu", ('stepSize="0.012"', f'stepSize="{step}"'))
    code = main(["run", "--controller", str(slow), "--scenario", "fsi", "--trajectory", "0", "--stop-time", "0.6", "--fmus",
                 str(fmus), "--out", str(tmp_path), "--quiet", "--no-plots", "--no-gusts"])
    if not ok:
        assert code == 2 and "declares stepSize 0.02 s, not a whole multiple of the 12 ms tick" in capsys.readouterr().err
        return
    assert code == 0
    times = [m["t"] for m in log_reader.read(next(tmp_path.glob("*.mcap")), topics=["/controller"])["/controller"]]
    # one sample a period of 24 ms, from its step at t = 0 (not its initial outputs as well) to its closing one at 0.6 s
    assert times == pytest.approx([0.024 * k for k in range(26)])

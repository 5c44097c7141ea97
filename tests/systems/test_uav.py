"""The UAV alone (Appendix A): trim (A.4), physics invariants, the loop with the ZSE."""

from __future__ import annotations

import numpy as np
import pytest
from fmpy import read_model_description
from fmpy.validation import validate_fmu
from support import ROOT
from support import physics_oracle as ref
from support.fmi2_session import session
from tiltload.master.app.cli import main
from tiltload.master.engine.log import reader as log_reader
from tiltload.plant_fmu.trim import hover_trim

STATES = ["x", "y", "z", "phi", "theta", "psi", "alpha_R", "alpha_L"]
STATES += [f"{s}_dot" for s in STATES]
TUMBLE = dict(zip(STATES, [0.1, -0.2, 0.3, 0.3, -0.2, 0.4, 0.2, -0.15, 0.2, -0.1, 0.3, 0.4, -0.3, 0.5, 0.35, -0.25]))




# (A.4), as printed: phi, theta, alpha_R, alpha_L (rad), f_R, f_L (N)
A4 = {"phi": -0.00015712, "theta": -0.02887388, "psi": 0.0, "alpha_R": 0.02899790, "alpha_L": 0.02853108}


A4_U = {"f_R": 9.74110841, "f_L": 9.77602843, "tau_R": 0.0, "tau_L": 0.0}


@pytest.fixture(scope="module")
def uav_fmus():
    from tiltload.master.app.loop.fmus import build_all

    return {r.path.stem: r.path for r in build_all(ROOT / "fmus", progress=lambda *_: None, vehicles=("uav",))}


def test_the_trim_is_a4_to_every_printed_digit():
    trim = hover_trim(vehicle="uav")
    q = dict(zip(STATES, trim.x))
    for name, printed in A4.items():
        assert round(q[name], 8) == printed, name
    for name, printed in zip(A4_U, trim.u):
        assert round(printed, 8) == A4_U[name], name
    assert trim.residual < 1e-12 and np.all(trim.x[8:] == 0.0)


def test_the_fmu_validates_and_starts_at_that_trim(uav_fmus):
    plant = uav_fmus["TiltrotorUAV"]
    assert validate_fmu(str(plant)) == []
    md = read_model_description(str(plant))
    start = {v.name: float(v.start) for v in md.modelVariables if v.start is not None and v.type == "Real"}
    for name, printed in A4.items():
        assert round(start[f"{name}_0"], 8) == printed
    for name, printed in A4_U.items():
        assert round(start[name], 8) == printed
    names = {v.name for v in md.modelVariables}
    assert "m_L" not in names and "l" not in names and "gamma_1" not in names  # no load, no rod


def _run(plant, params, stop, record, dt=0.012, inputs=None):
    with session(str(plant)) as s:
        s.set(**params, **{f"{k}_0": v for k, v in TUMBLE.items()})
        s.set(f_R=0.0, f_L=0.0, tau_R=0.0, tau_L=0.0)
        s.start()
        if inputs:
            s.set(**inputs)
        return s.run(stop, dt, record=record)


def test_energy_is_conserved_with_no_inputs(uav_fmus):
    rows = _run(uav_fmus["TiltrotorUAV"], {}, 2.0, STATES + ["E_total"])
    e_ref = np.array([ref.energy(r[:16]) for r in rows])
    np.testing.assert_allclose(rows[:, 16], e_ref, rtol=1e-12, atol=1e-12)  # the FMU's energy = the reimplementation's
    assert np.max(np.abs(e_ref - e_ref[0])) / np.max(np.abs(e_ref)) < 1e-7
    assert np.ptp(rows[:, 5]) > 0.1  # it really tumbled


def test_momenta_are_conserved_without_gravity(uav_fmus):
    names = STATES + ["p_x", "p_y", "p_z", "L_x", "L_y", "L_z"]
    rows = _run(uav_fmus["TiltrotorUAV"], {"g": 0.0}, 2.0, names)
    p = np.array([ref.linear_momentum(r[:16]) for r in rows])
    L = np.array([ref.angular_momentum(r[:16]) for r in rows])
    np.testing.assert_allclose(rows[:, 16:19], p, atol=1e-12)
    np.testing.assert_allclose(rows[:, 19:22], L, atol=1e-12)
    assert np.max(np.abs(p - p[0])) < 1e-9 and np.max(np.abs(L - L[0])) < 1e-9
    assert np.linalg.norm(p[0]) > 0.1 and np.linalg.norm(L[0]) > 0.01


def test_momentum_rate_equals_thrusts_weights_and_the_disturbance(uav_fmus):
    """d p/dt = thrusts + weights + d, with d on the geometric centre (A.1): integrated by Simpson on a 0.5 ms grid."""
    from scipy.integrate import simpson

    u = dict(f_R=9.0, f_L=11.5, tau_R=0.01, tau_L=-0.02, d_x=0.3, d_y=-0.2, d_z=0.1)
    dt = 0.0005
    rows = _run(uav_fmus["TiltrotorUAV"], {"integrator_step": dt}, 0.3, STATES, dt=dt, inputs=u)
    p = np.array([ref.linear_momentum(r) for r in rows])
    F = np.array([ref.external_force(r, u["f_R"], u["f_L"], [u["d_x"], u["d_y"], u["d_z"]]) for r in rows])
    impulse = simpson(F, dx=dt, axis=0)
    np.testing.assert_allclose(p[-1] - p[0], impulse, rtol=0, atol=1e-7 * np.max(np.abs(impulse)))


def _containment(log) -> tuple[int, int]:
    data = log_reader.read(log, topics=["/plant", "/controller"])
    plant = {round(m["t"], 6): m for m in data["/plant"]}
    ticks = outside = 0
    for m in data["/controller"]:
        key = round(m["t"], 6)
        if key not in plant or m["est_x_hi"] == m["est_x_lo"]:  # the message before the first estimate
            continue
        ticks += 1
        outside += any(not m[f"est_{n}_lo"] <= plant[key][n] <= m[f"est_{n}_hi"] for n in STATES)
    return ticks, outside


@pytest.mark.slow
def test_the_loop_tracks_appendix_a_with_the_zse_which_contains_the_truth(uav_fmus, tmp_path, capsys):
    """80 s of the circle of Sec. A.4 with gusts and sensor noise: near-zero steady error, the truth inside the
    zonotope's interval hull at every tick of the nonlinear loop."""
    code = main(["run", "--vehicle", "uav", "--scenario", "zse", "--fmus", str(uav_fmus["TiltrotorUAV"].parent),
                 "--out", str(tmp_path), "--quiet"])
    assert code == 0, capsys.readouterr().err
    log = tmp_path / "uav_zse_traj3_dlqr_seed1.mcap"
    ticks, outside = _containment(log)
    # 80 s is no whole number of 12 ms ticks: the run ends at the first tick after it (6667 ticks, 80.004 s) and the
    # controller's sample there closes its channel (docs/master.md, the edges): 6668 estimates, each holding the truth
    assert ticks == 6668 and outside == 0
    data = log_reader.read(log, topics=["/plant", "/scenario"])
    ref_at = {round(m["t"], 6): m for m in data["/scenario"]}
    late = [(m, ref_at[round(m["t"], 6)]) for m in data["/plant"] if m["t"] > 70 and round(m["t"], 6) in ref_at]
    error = np.array([[p[a] - r[f"{a}_ref"] for a in "xyz"] for p, r in late])
    assert np.sqrt(np.mean(error**2, axis=0)).max() < 0.1  # the last 10 s, after three gusts: centimetres
    figures = {f.name.split("seed1_")[1] for f in tmp_path.glob("*.png")}
    assert {"trajectory3d.png", "disturbances.png", "tracking_error.png", "remaining_dof.png", "actuators.png",
            "estimation_error.png", "estimation_error_rest.png"} <= figures  # the kinds of Figs. A.2-A.8

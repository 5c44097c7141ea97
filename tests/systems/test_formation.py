"""The formation of three UAVs (Appendix B)."""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest
from support.fmi2_session import session
from tiltload.formation import dualquat as dq
from tiltload.formation import kinematics as kin
from tiltload.master.engine.log import reader as log_reader

RNG = np.random.default_rng(7)


def _dqr():
    import dqrobotics  # the independent reference; a [test] dependency, imported here because it loads slowly

    return dqrobotics


def _random_unit(angle: float | None = None):
    dqr = _dqr()
    axis = RNG.normal(size=3)
    axis /= np.linalg.norm(axis)
    th = RNG.uniform(-3, 3) if angle is None else angle
    r = dqr.DQ(np.r_[math.cos(th / 2), math.sin(th / 2) * axis])
    p = dqr.DQ(np.r_[0.0, RNG.normal(size=3)])
    return r + dqr.DQ.E * 0.5 * p * r


def _num(x) -> np.ndarray:
    return np.array(ca.DM(x)).ravel() if not isinstance(x, np.ndarray) else x


@pytest.mark.parametrize("angle", [None, None, 1e-2, 1e-5, 0.0])
def test_dual_quaternions_agree_with_dqrobotics(angle):
    dqr = _dqr()
    a, b = _random_unit(angle), _random_unit()
    A, B = ca.DM(dqr.vec8(a)), ca.DM(dqr.vec8(b))
    np.testing.assert_allclose(_num(dq.mul(A, B)), dqr.vec8(a * b), atol=1e-14)
    np.testing.assert_allclose(np.array(dq.hplus8(A)), dqr.hamiplus8(a), atol=0)
    np.testing.assert_allclose(np.array(dq.hminus8(A)), dqr.haminus8(a), atol=0)
    np.testing.assert_allclose(_num(dq.conj(A)), dqr.vec8(dqr.conj(a)), atol=0)
    for exponent in (1 / 3, 0.5, 2.0):
        np.testing.assert_allclose(_num(dq.power(A, exponent)), dqr.vec8(dqr.pow(a, exponent)), atol=1e-13)


def test_dual_quaternion_identities():
    dqr = _dqr()
    x = ca.DM(dqr.vec8(_random_unit()))
    one = np.r_[1.0, np.zeros(7)]
    np.testing.assert_allclose(_num(dq.mul(x, dq.conj(x))), one, atol=1e-14)  # unit: x x* = 1
    # exp(a log x) with log x = theta n / 2 + eps p / 2: x^1 = x, x^0 = 1, (x^a)^b = x^(ab)
    np.testing.assert_allclose(_num(dq.power(x, 1.0)), _num(x), atol=1e-14)
    np.testing.assert_allclose(_num(dq.power(x, 0.0)), one, atol=1e-14)
    np.testing.assert_allclose(_num(dq.power(dq.power(x, 0.5), 2 / 3)), _num(dq.power(x, 1 / 3)), atol=1e-13)
    # a translation along the rotation axis is a screw: there phi phi-th parts make the whole
    screw = ca.DM(dqr.vec8(dqr.DQ([math.cos(0.4), 0, 0, math.sin(0.4)]) + dqr.DQ.E * 0.5 * dqr.DQ([0, 0, 0, 1.3])
                           * dqr.DQ([math.cos(0.4), 0, 0, math.sin(0.4)])))
    third = dq.power(screw, 1 / 3)
    np.testing.assert_allclose(_num(dq.mul(third, dq.mul(third, third))), _num(screw), atol=1e-13)
    h1, h2 = ca.DM(RNG.normal(size=4)), ca.DM(RNG.normal(size=4))
    np.testing.assert_allclose(_num(ca.mtimes(dq.hplus4(h1), h2)), _num(ca.mtimes(dq.hminus4(h2), h1)), atol=1e-14)
    p, yaw = np.array([0.3, -1.2, 2.0]), 0.7
    np.testing.assert_allclose(_num(dq.translation(dq.pose(p, yaw))), p, atol=1e-14)


def _jacobian():
    rho = ca.SX.sym("rho", 12)
    return ca.Function("J", [rho], [ca.jacobian(kin.task_pose(rho), rho)]), ca.Function("x", [rho], [kin.task_pose(rho)])


def test_task_space_jacobian_is_the_derivative_and_the_thesis_formula():
    J, x = _jacobian()
    rho = kin.formation_start(3.0) + RNG.normal(scale=0.3, size=12)
    Jv = np.array(J(rho))
    h = 1e-6
    fd = np.column_stack([(np.array(x(rho + h * e)) - np.array(x(rho - h * e))).ravel() / (2 * h) for e in np.eye(12)])
    np.testing.assert_allclose(Jv, fd, atol=1e-8)
    assert np.linalg.matrix_rank(Jv) == 12  # full column rank: J_S^+ = (J'J)^-1 J'
    # (B.4): J_r = [H8-(x_tau) E8 J_zeta, H8+(x_zeta*) J_tau], with J_i the Jacobian of the UAV's own pose (B.1)
    r = ca.SX.sym("r", 4)
    Ji = ca.Function("Ji", [r], [ca.jacobian(dq.pose(r[0:3], r[3]), r)])
    x_zeta, x_tau = (dq.pose(ca.DM(rho[4 * i:4 * i + 3]), rho[4 * i + 3]) for i in (1, 2))
    E8 = np.diag([1, -1, -1, -1, 1, -1, -1, -1])
    J_r = np.hstack([np.array(dq.hminus8(x_tau)) @ E8 @ np.array(Ji(rho[4:8])),
                     np.array(dq.hplus8(dq.conj(x_zeta))) @ np.array(Ji(rho[8:12]))])
    np.testing.assert_allclose(Jv[8:16, 4:12], J_r, atol=1e-12)
    np.testing.assert_allclose(Jv[8:16, 0:4], 0.0, atol=0)  # x_r does not depend on the leader


def test_the_references_describe_the_formation_start():
    f = kin.formation_functions()[0]
    for t in (0.0, 7.3):
        _, _, e_A = f(kin.formation_start(t), np.zeros(12), np.zeros(24), t, 0, np.zeros(12))
        assert np.abs(np.array(e_A)).max() < 1e-12


def _kinematic_loop(law: int, disturbance: np.ndarray, stop: float = 60.0, h: float = 0.012):
    f = kin.formation_functions()[0]
    rho = kin.formation_start(0.0) + np.tile([0.3, -0.2, 0.2, 0.0], 3)
    v, e_C = np.zeros(12), np.zeros(24)
    for i in range(int(round(stop / h))):
        a, e_B, e_A = (np.array(o).ravel() for o in f(rho, v, e_C, i * h, law, disturbance))
        rho, v, e_C = rho + h * v + 0.5 * h * h * a, v + h * a, e_C + h * e_B
    return rho, np.linalg.norm(e_A)


@pytest.mark.slow
def test_both_laws_converge_and_only_backstepping_rejects_a_constant_disturbance():
    d = np.tile([0.3, -0.2, 0.1, 0.0], 3)
    assert _kinematic_loop(0, np.zeros(12))[1] < 1e-3 and _kinematic_loop(1, np.zeros(12))[1] < 1e-3
    assert _kinematic_loop(0, d)[1] < 5e-3  # integral action e_C removes it
    rho, err = _kinematic_loop(1, d)
    J = np.array(_jacobian()[0](rho))
    predicted = np.linalg.norm(J @ d) / kin.Gains().K_2  # TSID: e_A'' = -K1 e_A' - K2 e_A + J d  ->  e_A = J d / K2
    assert err == pytest.approx(predicted, rel=0.05) and err > 0.05


@pytest.fixture(scope="module")
def formation_fmus(pipeline_fmus):
    from tiltload.master.app.loop.fmus import build_formation as build_fmus

    fmus = pipeline_fmus["TiltloadPlant"].parent
    build_fmus(fmus, progress=lambda *_: None)
    return fmus


def test_d_stable_design_meets_its_regions_on_every_vertex(formation_fmus):
    from tiltload.formation import dstable
    from tiltload.formation.build import cached_design

    d = cached_design()
    K = d["K"]
    for A, B, _, _ in dstable.vertices():
        poles = np.linalg.eigvals(A - B @ K)
        assert poles.real.max() < -dstable.LAMBDA  # Re(s) < -2.2
        assert np.abs(poles - dstable.DISC_C).max() < dstable.DISC_R  # |s| < 100
        assert (np.abs(poles.imag) <= math.tan(dstable.CONE_MU) * np.abs(poles.real)).all()  # the cone
    assert all(h <= d["gamma"] for h in d["hinf"])  # the bound holds where it is measured


def test_tracker_fmu_is_the_python_law(formation_fmus):
    """TiltrotorTracker.fmu's command against control_law.StateFeedback with the same gain and feedforward."""
    from tiltload.controller_fmu.design import feedforward as ff
    from tiltload.controller_fmu.design.control_law import StateFeedback
    from tiltload.formation.build import cached_design
    from tiltload.formation.fmu_variables import TICK
    from tiltload.master.app.formation.system import REFERENCES, STATES
    from tiltload.plant_fmu.vehicles import VEHICLES

    d = cached_design()
    law = StateFeedback(d["K"], TICK, d["trim_x"], ff.bound(VEHICLES["uav"].default_parameters(), vehicle="uav"))
    worst = 0.0
    with session(formation_fmus / "TiltrotorTracker.fmu", instance="tracker") as tracker:
        tracker.start()
        for k in range(50):
            x = d["trim_x"] + RNG.normal(scale=0.02, size=16)
            ref = np.r_[0.1 * k * TICK, 0.0, 0.05, 0.1, 0.0, 0.0, 0.2, -0.1, 0.05, 0.0, 0.0]
            tracker.set(**dict(zip(STATES, x)), **dict(zip(REFERENCES, ref)))
            tracker.fmu.doStep(k * TICK, TICK)
            u = law(x, ref[0:3], ref[3:6], ref[6:9], ref[9], ref[10])
            worst = max(worst, np.abs(np.array(tracker.get("f_R", "f_L", "tau_R", "tau_L")) - u).max())
    assert worst < 1e-9


def test_formation_fmu_is_the_python_law(formation_fmus):
    """FormationController.fmu's references: the CasADi law and the integration of Sec. B.3.4, in Python."""
    from tiltload.formation.fmu_variables import MEASURED, TICK
    from tiltload.master.app.formation.system import REFERENCES

    f = kin.formation_functions()[0]
    rho_ref, rho_dot_ref, e_C = None, None, np.zeros(24)
    worst = 0.0
    with session(formation_fmus / "FormationController.fmu", instance="formation") as fmu:
        fmu.set_typed(controller="backstepping")
        fmu.set(sigma_ax_disturbance=0.2, tau_az_disturbance=-0.1, disturbance_start=0.1)
        fmu.start()
        for k in range(60):
            t = k * TICK
            rho = kin.formation_start(t) + RNG.normal(scale=0.05, size=12)
            rho_dot = RNG.normal(scale=0.1, size=12)
            inputs = {}
            for i, a in enumerate(kin.AGENTS):
                values = [*rho[4 * i:4 * i + 4], *rho_dot[4 * i:4 * i + 4]]
                inputs.update({f"{a}_{n}": v for (n, _), v in zip(MEASURED, values)})
            fmu.set(**inputs)
            fmu.fmu.doStep(t, TICK)
            if rho_ref is None:
                rho_ref, rho_dot_ref = rho.copy(), rho_dot.copy()
            d = np.zeros(12)
            if t >= 0.1 - 1e-9:
                d[0], d[10] = 0.2, -0.1
            a_, e_B, _ = (np.array(o).ravel() for o in f(rho, rho_dot, e_C, t, 0, d))
            expected = []
            for i in range(3):
                expected += [*rho_ref[4 * i:4 * i + 3], *rho_dot_ref[4 * i:4 * i + 3], *a_[4 * i:4 * i + 3], rho_ref[4 * i + 3],
                             rho_dot_ref[4 * i + 3]]
            got = fmu.get(*[f"{a}_{r}" for a in kin.AGENTS for r in REFERENCES])
            worst = max(worst, np.abs(np.array(got) - expected).max())
            rho_ref, rho_dot_ref = rho_ref + TICK * rho_dot_ref + 0.5 * TICK**2 * a_, rho_dot_ref + TICK * a_
            e_C = e_C + TICK * e_B
    assert worst < 1e-9


def _run(fmus, controller, disturbances, stop):
    from tiltload.master.app.formation.system import formation_system
    from tiltload.master.engine.execution import Execution

    ex = Execution(formation_system(fmus, controller, disturbances))
    try:
        ex.instantiate()
        assert len(ex.instances) == 7
        vr = ex.instances["formation"].vars["error_norm"].valueReference
        norms = []
        for _ in range(int(round(stop / ex.system.tick))):
            ex.step_tick()
            norms.append(ex.instances["formation"].slave.getReal([vr])[0])
        return np.array(norms)
    finally:
        ex.close()


@pytest.mark.slow
def test_seven_fmus_in_one_deterministic_run(formation_fmus):
    first, again = _run(formation_fmus, "backstepping", True, 15.0), _run(formation_fmus, "backstepping", True, 15.0)
    assert np.array_equal(first, again)
    assert first[0] > 0.5 and first[int(9.9 / 0.004)] < 0.1  # converged before the disturbances at 10 s


@pytest.mark.slow
def test_with_disturbances_backstepping_rejects_and_tsid_does_not(formation_fmus):
    """Sec. B.4's finding, through the seven FMUs (inner loops, plants with external forces): 60 s."""
    back, tsid = _run(formation_fmus, "backstepping", True, 60.0), _run(formation_fmus, "tsid", True, 60.0)
    tail = slice(int(55 / 0.004), None)
    assert back[tail].max() < 0.01 and back[-1] < back[int(30 / 0.004)] / 5  # decaying towards zero
    assert tsid[tail].min() > 0.2 and np.ptp(tsid[tail]) < 1e-3  # a constant offset
    calm = _run(formation_fmus, "tsid", False, 60.0)
    assert calm[tail].max() < 1e-3


def test_formation_command(formation_fmus, tmp_path, capsys):
    from tiltload.master.app.cli import main

    assert main(["formation", "--controller", "tsid", "--stop-time", "2", "--fmus", str(formation_fmus), "--out", str(tmp_path),
                 "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "7 FMUs" in out and (tmp_path / "tsid.mcap").is_file() and (tmp_path / "error_norm.png").is_file()
    from tiltload.master.engine.log import reader as log_reader

    topics = log_reader.read(tmp_path / "tsid.mcap", topics=["/scene/plant_sigma", "/scene/plant_tau"])
    assert topics["/scene/plant_sigma"] and topics["/scene/plant_tau"]  # one 3D scene per UAV


def test_the_formation_layout_is_current_and_plots_paths_the_log_has(formation_fmus, tmp_path):
    import json

    from tiltload.master.app.formation.runner import run
    from tiltload.master.app.views import foxglove_layout

    shipped = foxglove_layout.layout_json(formation=True)
    assert (formation_fmus.parent / "docs" / "foxglove_layout_formation.json").read_text() == shipped
    r = run(formation_fmus, tmp_path, "backstepping", False, stop=0.2, progress=False)
    text = json.dumps(json.loads(shipped))
    data = log_reader.read(r.log)
    for series in foxglove_layout.FORMATION_PATHS.values():
        for path, _ in series:
            topic, field = path.rsplit(".", 1)
            assert f'"{path}"' in text and field in data[topic][-1], path
    for topic in foxglove_layout.FORMATION_SCENES:
        assert f'"{topic}"' in text and data[topic]

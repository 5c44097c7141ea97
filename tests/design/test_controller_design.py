"""Controller design (ch. 3): DLQR optimality, the LMI designs' guarantees on the returned gain, named failures."""

from __future__ import annotations

import numpy as np
import pytest
from tiltload.controller_fmu.design import artifact
from tiltload.controller_fmu.design.dlqr import design_dlqr
from tiltload.controller_fmu.design.error_dynamics import DesignError, ErrorDynamics, error_dynamics
from tiltload.controller_fmu.design.feedforward import feedforward
from tiltload.controller_fmu.design.synthesize import design
from tiltload.controller_fmu.design.weights import omega_chi, omega_u
from tiltload.controller_fmu.reference.closed_loop import simulate


@pytest.fixture(scope="module")
def dlqr():
    return design("dlqr")


def test_dare_holds_and_closed_loop_is_stable(dlqr):
    A, B, K, Q, R = dlqr.A, dlqr.B, dlqr.K, dlqr.omega_chi, dlqr.omega_u
    sol = design_dlqr(error_dynamics(), Q, R)
    P = sol.P
    # P = A'PA + Q - A'PB (B'PB + R)^-1 B'PA, and K = (B'PB + R)^-1 B'PA
    residual = A.T @ P @ A + Q - A.T @ P @ B @ np.linalg.solve(B.T @ P @ B + R, B.T @ P @ A) - P
    assert np.abs(residual).max() < 1e-9 * np.abs(P).max()
    np.testing.assert_allclose(K, np.linalg.solve(B.T @ P @ B + R, B.T @ P @ A), rtol=1e-9, atol=1e-12)
    assert np.max(np.abs(np.linalg.eigvals(A - B @ K))) < 1.0
    assert np.linalg.eigvalsh(P)[0] > 0


def test_dlqr_is_optimal_against_perturbed_gains(dlqr):
    """The LQ cost x0' P x0 of K is lower than that of nearby stabilizing gains."""
    from scipy.linalg import solve_discrete_lyapunov

    A, B, Q, R = dlqr.A, dlqr.B, dlqr.omega_chi, dlqr.omega_u
    def cost(K):
        Acl = A - B @ K
        return np.trace(solve_discrete_lyapunov(Acl.T, Q + K.T @ R @ K))
    base = cost(dlqr.K)
    rng = np.random.default_rng(0)
    for _ in range(5):
        assert cost(dlqr.K * (1 + 0.02 * rng.normal(size=dlqr.K.shape))) > base


def test_same_inputs_give_the_same_design(dlqr, tmp_path):
    again = design("dlqr")
    assert np.array_equal(dlqr.K, again.K)
    loaded = artifact.load(artifact.save(dlqr, tmp_path / "d.json"))
    assert np.array_equal(loaded.K, dlqr.K) and loaded.parameter_hash == dlqr.parameter_hash


def test_feedforward_at_hover_is_the_trim_input(dlqr):
    u = feedforward(dlqr.trim_x[:10], np.zeros(10), np.zeros(10), dlqr.params)
    np.testing.assert_allclose(u, dlqr.trim_u, atol=1e-10)


@pytest.mark.parametrize(
    "Q, R, needle",
    [
        (np.eye(23), np.eye(4), "Omega_chi must be 24x24"),
        (np.triu(np.ones((24, 24))), np.eye(4), "Omega_chi must be symmetric"),
        (-np.eye(24), np.eye(4), "Omega_chi must be positive semidefinite"),
        (np.eye(24), np.diag([1, 1, 1, 0.0]), "Omega_u must be positive definite"),
        (np.eye(24), np.full((4, 4), np.nan), "Omega_u has non-finite"),
    ],
)
def test_bad_weights_are_named(Q, R, needle):
    with pytest.raises(DesignError, match=needle):
        design_dlqr(error_dynamics(), Q, R)


def test_uncontrollable_system_is_refused():
    sys = error_dynamics()
    bad = ErrorDynamics(sys.A, np.zeros_like(sys.B), sys.F, sys.Tc, sys.trim, sys.params)
    with pytest.raises(DesignError, match="no stabilizing solution|not stable"):
        design_dlqr(bad, omega_chi(), omega_u(sys.trim.u))


def test_bad_sampling_time_and_unknown_kind():
    with pytest.raises(DesignError, match="T_c"):
        error_dynamics(Tc=0.0)
    with pytest.raises(DesignError, match="unknown controller"):
        design("pid")


def returns_from_30cm_and_rejects_a_step(d, axis):
    """Hover set-point from a 30 cm offset, then a 0.1 N step on the load along axis at t = 15 s."""
    x0 = d.trim_x.copy()
    x0[0:3] += 0.3
    force = np.eye(3)[axis] * 0.1
    log = simulate(d, x0, stop=30.0, disturbance=lambda t: force if t >= 15.0 else np.zeros(3))
    err = log["x"][:, [0, 1, 2, 5]] - d.trim_x[[0, 1, 2, 5]]
    t = log["t"]
    assert np.abs(err[(t > 12) & (t < 15)]).max() < 2e-3  # back at the set-point
    assert np.abs(err[(t > 15) & (t < 17)]).max() > 0.05  # the step does push the load ...
    assert np.abs(err[t > 28]).max() < 2e-3  # ... and integral action removes the offset
    assert np.all(np.abs(log["u"][:, 2:]) <= 2.0) and np.all(log["u"][:, :2] >= 0)


@pytest.mark.slow
def test_dlqr_on_the_nonlinear_plant(dlqr):
    returns_from_30cm_and_rejects_a_step(dlqr, axis=0)


@pytest.fixture(scope="module")
def mixed():
    return design("mixed", use_cache=True)  # about 10 s on a cold cache (SDPA)


def test_mixed_design_meets_its_guarantees_on_the_returned_gain(mixed):
    """Checked on K itself, not on the solver's status: regions, H-infinity bound, stability."""
    poles = np.linalg.eigvals(mixed.A - mixed.B @ mixed.K)
    assert poles.real.min() > 0.55 and np.abs(poles).max() < 0.99402
    from tiltload.controller_fmu.design.lmi_check import measured_norms
    from tiltload.controller_fmu.design.problems import problem

    r = mixed.report
    # measured here on the closed loop of K (a shipped design's report leaves them to be measured on demand)
    hinf_norm, h2_norm = measured_norms(*problem("mixed", mixed.Tc), mixed.K)
    assert hinf_norm < 24.0  # the prescribed bound gamma~ = 24^2 of Sec. 5.2
    assert all(v > 0 for v in r["lmi_min_eig"].values())  # every LMI holds at the returned point
    assert h2_norm <= r["h2_bound"] * (1 + 1e-9)
    if r["hinf_norm"] is not None:  # synthesized here: the report's own figures are these
        assert r["hinf_norm"] == pytest.approx(hinf_norm, rel=1e-9) and r["h2_norm"] == pytest.approx(h2_norm, rel=1e-9)


@pytest.mark.slow
def test_mixed_design_on_the_nonlinear_plant(mixed):
    returns_from_30cm_and_rejects_a_step(mixed, axis=1)


def test_empty_region_is_refused():
    from tiltload.controller_fmu.design.lmi import synthesize

    sys = error_dynamics()
    with pytest.raises(DesignError, match="region is empty"):
        synthesize(sys, omega_chi(), omega_u(sys.trim.u), eps=0.9, varpi=0.8)


def small_system(Tc=0.05):
    """A cart (double integrator) with integral action, discretized: a quick LMI problem."""
    from tiltload.plant_fmu.linearize import zoh

    Ac = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    A, BF = zoh(Ac, np.array([[0.0, 0.0], [1.0, 1.0], [0.0, 0.0]]), Tc)
    return ErrorDynamics(A, BF[:, :1], BF[:, 1:], Tc, None, None)


@pytest.mark.slow
def test_mixed_synthesis_is_deterministic_and_feasible_at_its_point():
    from tiltload.controller_fmu.design.lmi import synthesize

    sys, Q, R = small_system(), np.diag([10.0, 1.0, 1.0]), np.eye(1)
    a = synthesize(sys, Q, R, gamma_sq=30.0**2, eps=0.3, varpi=0.999)
    b = synthesize(sys, Q, R, gamma_sq=30.0**2, eps=0.3, varpi=0.999)
    assert np.array_equal(a.K, b.K) and a.h2_bound == b.h2_bound
    assert all(v > 0 for v in a.lmi_min_eig.values())
    poles = np.linalg.eigvals(sys.A - sys.B @ a.K)
    assert poles.real.min() > 0.3 and np.abs(poles).max() < 0.999 and a.hinf_norm < 30.0


@pytest.mark.slow
def test_infeasible_hinf_bound_is_named():
    """gamma~ below what any gain achieves (the pure H-infinity optimum) must fail as infeasible."""
    from tiltload.controller_fmu.design.lmi import synthesize

    sys, Q, R = small_system(), np.diag([10.0, 1.0, 1.0]), np.eye(1)
    best = synthesize(sys, Q, R, eps=0.3, varpi=0.999)
    with pytest.raises(DesignError, match="infeasible.*prescribed H-infinity bound"):
        synthesize(sys, Q, R, gamma_sq=(0.5 * best.gamma_bound) ** 2, eps=0.3, varpi=0.999)


@pytest.mark.slow
def test_sdpa_and_clarabel_agree_and_clarabel_takes_over_when_sdpa_fails(monkeypatch):
    """Two independent interior-point solvers on one problem: the same optimum to solver tolerance,
    and a failing SDPA (here: its child process exits) falls back to Clarabel, never to an unchecked point."""
    from tiltload.controller_fmu.design import sdp_solver
    from tiltload.controller_fmu.design.lmi import synthesize

    sys, Q, R = small_system(), np.diag([10.0, 1.0, 1.0]), np.eye(1)
    lines = []
    a = synthesize(sys, Q, R, gamma_sq=30.0**2, eps=0.3, varpi=0.999, progress=lines.append)
    assert a.solver == "SDPA" and a.iterations > 5
    monkeypatch.setattr(sdp_solver.sys, "executable", "/bin/false")  # the child cannot start
    b = synthesize(sys, Q, R, gamma_sq=30.0**2, eps=0.3, varpi=0.999, progress=lines.append)
    assert b.solver == "Clarabel"
    assert any("SDPA failed" in line and "Clarabel" in line for line in lines)
    assert b.h2_bound == pytest.approx(a.h2_bound, rel=1e-3)
    assert all(v > 0 for v in b.lmi_min_eig.values())


@pytest.mark.slow
def test_sdpa_reports_every_iteration_in_order():
    import cvxpy as cp
    from tiltload.controller_fmu.design import sdp_solver

    X = cp.Variable((3, 3), symmetric=True)
    problem = cp.Problem(cp.Minimize(cp.trace(X)), [X >> np.diag([1.0, 2.0, 3.0])])
    seen = []
    solved = sdp_solver.solve_sdpa(problem, lambda k, mu, s: seen.append((k, mu)))
    assert solved.status == "optimal" and problem.value == pytest.approx(6.0, rel=1e-5)
    assert [k for k, _ in seen] == list(range(1, solved.iterations + 1))
    assert seen[-1][1] < 1e-3 * seen[0][1]  # the duality measure falls as the solver converges

"""The estimators (ch. 4): zonotope containment, the ZSE against the textbook algorithm, the LKF's consistency,
and the C estimators against the numpy reference."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import solve_discrete_are
from scipy.stats import chi2
from support.physics_oracle import zse_measurement
from tiltload.controller_fmu.design.estimator_setup import augmented_model, lkf_setup, zse_setup
from tiltload.controller_fmu.reference import native_estimators as c_estimators
from tiltload.controller_fmu.reference.lkf import KalmanFilter
from tiltload.controller_fmu.reference.zonotope import REDUCTIONS, ZonotopeError, contains_point, reduce_rows, support
from tiltload.controller_fmu.reference.zse import ZonotopicEstimator
from tiltload.sensor_fmu.measurement import pi, pi_jacobian

GPS, BARO, IMU, CAMERA, SERVOS = [0, 1], [2], list(range(3, 9)), [9, 10, 11], list(range(12, 16))


@pytest.fixture(scope="module")
def model():
    return augmented_model()


def available(k: int) -> np.ndarray:
    """I_k of Table 5.8 at tick k: GPS every 10 ticks, camera every 2, the rest every tick."""
    mask = np.zeros(16, dtype=bool)
    mask[BARO + IMU + SERVOS] = True
    mask[GPS] = k % 10 == 0
    mask[CAMERA] = k % 2 == 0
    return mask


def test_measurement_model_matches_the_thesis_formulas(model):
    rng = np.random.default_rng(1)
    p = model.params
    for _ in range(5):
        x = model.trim.x + np.concatenate([rng.normal(0, 0.3, 10), rng.normal(0, 1.0, 10)])
        np.testing.assert_allclose(pi(x, p), zse_measurement(x), atol=1e-12)
    x, h = model.trim.x, 1e-6
    fd = np.column_stack([(zse_measurement(x + h * e) - zse_measurement(x - h * e)) / (2 * h) for e in np.eye(20)])
    np.testing.assert_allclose(pi_jacobian(x, p), fd, atol=1e-8)


def random_zonotope(rng, n=6, r=40):
    return rng.normal(size=n), rng.normal(size=(r, n)) * rng.exponential(size=(r, 1))


@pytest.mark.parametrize("method", REDUCTIONS)
def test_each_reduction_contains_its_input(method):
    rng = np.random.default_rng(2)
    for _ in range(20):
        c, Gt = random_zonotope(rng)
        red = reduce_rows(Gt, 12, method)
        assert red.shape == (12, 6)
        d = rng.normal(size=(6, 500))
        assert np.all(support(c, red, d) >= support(c, Gt, d) - 1e-12)


def textbook_zse_step(A, B, H, c_w, Gw, c_v, Gv, c, G, du, y, idx):
    """Alg. 4.4 as printed (sequential strips, no reduction), as the reference for the fast form."""
    c = A @ c + B @ du + c_w
    G = np.hstack([Gw, A @ G])
    for i in idx:
        rho, s, sigma = H[i], -c_v[i], np.abs(Gv[i]).sum()
        lam = G @ (G.T @ rho) / (rho @ G @ G.T @ rho + sigma**2)
        c = c + lam * (y[i] + s - rho @ c)
        G = np.hstack([(np.eye(len(c)) - np.outer(lam, rho)) @ G, sigma * lam[:, None]])
    return c, G


def test_fast_update_equals_the_textbook_algorithm(model):
    z = zse_setup(model)
    rng = np.random.default_rng(3)
    est = ZonotopicEstimator(model.A, model.B, z.H, np.zeros(23), z.G_w, z.y_eq, z.G_v, r_max=10_000)
    c0, G0 = np.zeros(23), z.G_x0[:, np.any(z.G_x0 != 0, axis=0)]
    est.initialize(c0, G0)
    c, G = c0, G0
    nu = G0 @ rng.uniform(-1, 1, G0.shape[1])
    for k in range(1, 8):
        du = rng.normal(size=4) * 0.1
        nu = model.A @ nu + model.B @ du + np.diag(z.G_w) * rng.uniform(-1, 1, 23)
        y = z.y_eq + z.H @ nu + rng.uniform(-1, 1, 16) * np.diag(z.G_v)
        assert est.step(du, y, available(k)).used == available(k).sum()
        c, G = textbook_zse_step(model.A, model.B, z.H, np.zeros(23), z.G_w, z.y_eq, z.G_v, c, G, du, y, np.flatnonzero(available(k)))
        np.testing.assert_allclose(est.c, c, atol=1e-12)
        np.testing.assert_allclose(est.Gt.T @ est.Gt, G @ G.T, atol=1e-12)
        np.testing.assert_allclose(est.hull, np.abs(G).sum(axis=1), rtol=1e-10)


def lqr_gain(model):
    A, B = model.A[:20, :20], model.B[:20]
    P = solve_discrete_are(A, B, np.eye(20), np.eye(4))
    return np.linalg.solve(B.T @ P @ B + np.eye(4), B.T @ P @ A)


@pytest.fixture(scope="module")
def c_library(pipeline_fmus, tmp_path_factory):
    """The controller FMU's C estimators, compiled from its sources/ (controller_fmu/reference/native_estimators.py)."""
    return c_estimators.compile_library(pipeline_fmus["TiltloadController"], tmp_path_factory.mktemp("c_estimators"))


def make_zse(impl, c_library, *args, **kw):
    if impl == "c":
        return c_estimators.CZonotopicEstimator(c_library, *args, **kw)
    return ZonotopicEstimator(*args, **kw)


@pytest.mark.parametrize("impl, reduction", [("python", "combastel"), ("c", "combastel"), ("c", "girard"), ("c", "pca")])
@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.slow
def test_zse_contains_the_true_state_for_10000_steps(model, seed, impl, reduction, request):
    """Linear model, noise inside W_bar and V_bar (vertices included), multirate measurements, reduction active.

    Run on the Python reference and on the C estimator the controller FMU ships (each reduction)."""
    c_library = request.getfixturevalue("c_library") if impl == "c" else None
    z = zse_setup(model)
    rng = np.random.default_rng(seed)
    K = lqr_gain(model)
    gw, gv = np.diag(z.G_w), np.diag(z.G_v)
    noise = lambda size, bound: bound * np.where(rng.random(size) < 0.2, rng.choice([-1.0, 1.0], size), rng.uniform(-1, 1, size))  # noqa: E731
    nu = z.G_x0 @ rng.uniform(-1, 1, 23)
    est = make_zse(impl, c_library, model.A, model.B, z.H, np.zeros(23), z.G_w, z.y_eq, z.G_v, z.r_max, reduction)
    est.initialize(np.zeros(23), z.G_x0, z.y_eq + z.H @ nu + noise(16, gv))
    dirs = rng.normal(size=(23, 16))
    lp_checked = 0
    for k in range(1, 10_001):
        du = -K @ est.c[:20]
        nu = model.A @ nu + model.B @ du + noise(23, gw)
        y = z.y_eq + z.H @ nu + noise(16, gv)
        report = est.step(du, y, available(k))
        assert not report.inconsistent and not report.skipped_nonfinite
        assert np.all(np.abs(nu - est.c) <= est.hull * (1 + 1e-9) + 1e-12), k
        assert np.all(dirs.T @ nu <= support(est.c, est.Gt, dirs) + 1e-10), k
        if k % 1000 == 0:
            assert contains_point(est.c, est.Gt, nu), k
            lp_checked += 1
    assert est.r == z.r_max and lp_checked == 10


def test_nonfinite_and_inconsistent_measurements_are_skipped_and_flagged(model):
    z = zse_setup(model)
    est = ZonotopicEstimator(model.A, model.B, z.H, np.zeros(23), z.G_w, z.y_eq, z.G_v, z.r_max)
    est.initialize(np.zeros(23), z.G_x0, z.y_eq)
    y = z.y_eq.copy()
    y[3], y[12] = np.nan, np.inf
    y[2] += 1e3  # barometer 1 km off: its strip cannot meet the predicted set
    report = est.step(np.zeros(4), y)
    assert report.skipped_nonfinite == [3, 12] and report.inconsistent == [2] and report.used == 13
    assert np.all(np.isfinite(est.c)) and np.all(np.isfinite(est.hull))


@pytest.mark.parametrize("change, needle", [
    (dict(H=np.zeros((16, 22))), "dimensions"),
    (dict(G_v=np.diag([np.nan] * 16)), "non-finite"),
    (dict(c_w=np.zeros(5)), "centre of size 5"),
    (dict(r_max=10), "r_max"),
    (dict(reduction="magic"), "unknown reduction"),
])
def test_bad_zse_setup_is_named(model, change, needle):
    z = zse_setup(model)
    args = dict(A=model.A, B=model.B, H=z.H, c_w=np.zeros(23), G_w=z.G_w, c_v=z.y_eq, G_v=z.G_v, r_max=z.r_max)
    args.update(change)
    with pytest.raises(ZonotopeError, match=needle):
        ZonotopicEstimator(**args)


@pytest.mark.slow
def test_lkf_error_is_consistent_with_its_covariance(model):
    """NEES over 40 Monte Carlo runs inside the two-sided 95 % chi-square band at >= 90 % of the steps."""
    s = lkf_setup()
    runs, steps, n = 40, 300, 23
    rng = np.random.default_rng(4)
    K = lqr_gain(model)
    Lw, sv = np.linalg.cholesky(s.Pw), np.sqrt(np.diag(s.Pv))
    nees, dof = np.zeros(steps), None
    for _ in range(runs):
        nu = np.linalg.cholesky(s.P0) @ rng.normal(size=n)
        f = KalmanFilter(model.A, model.B, s.H, s.Pw, s.Pv, np.zeros(n), s.P0)
        for k in range(steps):
            du = -K @ f.nu[:20]
            nu = model.A @ nu + model.B @ du + Lw @ rng.normal(size=n)
            f.step(du, s.H @ nu + sv * rng.normal(size=10))
            e = nu - f.nu
            # the angles are measured exactly (P^v = 0 there), so P is singular: NEES on its range
            Pinv = np.linalg.pinv(f.P, rcond=1e-9, hermitian=True)
            dof = np.linalg.matrix_rank(f.P, tol=1e-9 * np.abs(f.P).max(), hermitian=True)
            nees[k] += e @ Pinv @ e / runs
    lo, hi = chi2.ppf([0.025, 0.975], dof * runs) / runs
    assert np.mean((nees > lo) & (nees < hi)) >= 0.9


def test_lkf_position_error_falls_well_below_the_measurement_noise(model):
    s = lkf_setup()
    rng = np.random.default_rng(5)
    K = lqr_gain(model)
    f = KalmanFilter(model.A, model.B, s.H, s.Pw, s.Pv, np.zeros(23), s.P0)
    nu, errors = np.zeros(23), []
    Lw = np.linalg.cholesky(s.Pw)
    for k in range(3000):
        du = -K @ f.nu[:20]
        nu = model.A @ nu + model.B @ du + Lw @ rng.normal(size=23)
        f.step(du, s.H @ nu + np.sqrt(np.diag(s.Pv)) * rng.normal(size=10))
        if k > 500:
            errors.append(nu[:3] - f.nu[:3])
    std = np.std(errors, axis=0)
    assert np.all(std < 0.025)  # the thesis reports about 1.37 cm against 5 cm measured
    np.testing.assert_allclose(std, np.sqrt(np.diag(f.P)[:3]), rtol=0.15)  # and matches the filter's own sigma


@pytest.mark.parametrize("change, needle", [
    (dict(Pw=-np.eye(23)), "P\\^w is not positive semidefinite"),
    (dict(Pv=np.ones((10, 9))), "P\\^v must be 10x10"),
    (dict(P0=np.triu(np.ones((23, 23)))), "not symmetric"),
    (dict(nu0=np.full(23, np.nan)), "finite"),
])
def test_bad_lkf_setup_is_named(model, change, needle):
    s = lkf_setup()
    args = dict(A=model.A, B=model.B, H=s.H, Pw=s.Pw, Pv=s.Pv, nu0=np.zeros(23), P0=s.P0)
    args.update(change)
    with pytest.raises(ZonotopeError, match=needle):
        KalmanFilter(**args)


def test_lkf_skips_nonfinite_measurements(model):
    s = lkf_setup()
    f = KalmanFilter(model.A, model.B, s.H, s.Pw, s.Pv, np.zeros(23), s.P0)
    dy = np.zeros(10)
    dy[1] = np.nan
    assert f.step(np.zeros(4), dy) == [1]
    assert np.all(np.isfinite(f.nu)) and np.all(np.isfinite(f.P))


def closed_loop_sequence(model, z, steps, seed):
    """Measurements, inputs and availability of a closed linear loop (the Python estimator's centre steers)."""
    rng = np.random.default_rng(seed)
    K = lqr_gain(model)
    nu = z.G_x0 @ rng.uniform(-1, 1, 23)
    return rng, K, nu


@pytest.mark.parametrize("reduction", ["combastel", "girard"])
@pytest.mark.slow
def test_c_zse_equals_the_python_reference_for_3000_steps(model, c_library, reduction):
    """Centre and interval hull of the shipped C estimator against controller_fmu.zse, step by step."""
    z = zse_setup(model)
    args = (model.A, model.B, z.H, np.zeros(23), z.G_w, z.y_eq, z.G_v, z.r_max, reduction)
    py, c = ZonotopicEstimator(*args), c_estimators.CZonotopicEstimator(c_library, *args)
    rng, K, nu = closed_loop_sequence(model, z, 3000, 7)
    y0 = z.y_eq + z.H @ nu + np.diag(z.G_v) * rng.uniform(-1, 1, 16)
    py.initialize(np.zeros(23), z.G_x0, y0, available(0))
    c.initialize(np.zeros(23), z.G_x0, y0, available(0))
    worst = 0.0
    for k in range(1, 3001):
        du = -K @ py.c[:20]
        nu = model.A @ nu + model.B @ du + np.diag(z.G_w) * rng.uniform(-1, 1, 23)
        y = z.y_eq + z.H @ nu + np.diag(z.G_v) * rng.uniform(-1, 1, 16)
        assert py.step(du, y, available(k)) == c.step(du, y, available(k))
        worst = max(worst, np.abs(py.c - c.c).max(), np.abs(py.hull - c.hull).max())
    assert c.r == py.r == z.r_max  # the reduction ran
    assert worst <= 1e-9, worst


@pytest.mark.parametrize("reduction", ["combastel", "girard", "pca"])
@pytest.mark.slow
def test_c_zse_vector_copies_give_the_same_bits(model, c_library, pipeline_fmus, tmp_path, reduction):
    """The kernels this CPU dispatches to (AVX2, AVX-512VL or the baseline) and the baseline copy alone
    (-DTL_PORTABLE_FP) do the same IEEE operations in the same order: centre, hull and every generator equal
    to the bit over 300 closed-loop steps with the reduction active (docs/platforms.md)."""
    z = zse_setup(model)
    portable = c_estimators.compile_library(pipeline_fmus["TiltloadController"], tmp_path, ("-DTL_PORTABLE_FP",))
    args = (model.A, model.B, z.H, np.zeros(23), z.G_w, z.y_eq, z.G_v, z.r_max, reduction)
    a, b = c_estimators.CZonotopicEstimator(c_library, *args), c_estimators.CZonotopicEstimator(portable, *args)
    rng, K, nu = closed_loop_sequence(model, z, 300, 11)
    y0 = z.y_eq + z.H @ nu
    a.initialize(np.zeros(23), z.G_x0, y0, available(0))
    b.initialize(np.zeros(23), z.G_x0, y0, available(0))
    bits = lambda x: np.ascontiguousarray(x).view(np.int64)  # noqa: E731
    for k in range(1, 301):
        du = -K @ a.c[:20]
        nu = model.A @ nu + model.B @ du + np.diag(z.G_w) * rng.uniform(-1, 1, 23)
        y = z.y_eq + z.H @ nu + np.diag(z.G_v) * rng.uniform(-1, 1, 16)
        assert a.step(du, y, available(k)) == b.step(du, y, available(k))
        assert a.r == b.r
        for x, w in ((a.c, b.c), (a.hull, b.hull), (a.Gt, b.Gt)):
            np.testing.assert_array_equal(bits(x), bits(w), err_msg=f"step {k}")
    assert a.r == z.r_max  # the reduction ran


@pytest.mark.slow
def test_c_zse_pca_is_as_tight_as_the_python_pca(model, c_library):
    """PCA boxes the discarded generators in the eigenbasis of G'G. Near-equal eigenvalues make that basis
    ill-conditioned: the C (Jacobi) and numpy (LAPACK) bases differ at rounding level, the two estimators drop
    different generators from then on, and each keeps a different valid outer bound. So here the C PCA must be
    as tight as the Python one on average; its containment is tested over 10 000 steps above."""
    z = zse_setup(model)
    args = (model.A, model.B, z.H, np.zeros(23), z.G_w, z.y_eq, z.G_v, z.r_max, "pca")
    py, c = ZonotopicEstimator(*args), c_estimators.CZonotopicEstimator(c_library, *args)
    rng, K, nu = closed_loop_sequence(model, z, 1500, 8)
    y0 = z.y_eq + z.H @ nu
    py.initialize(np.zeros(23), z.G_x0, y0, available(0))
    c.initialize(np.zeros(23), z.G_x0, y0, available(0))
    widths_py, widths_c = [], []
    for k in range(1, 1501):
        du = -K @ py.c[:20]
        nu = model.A @ nu + model.B @ du + np.diag(z.G_w) * rng.uniform(-1, 1, 23)
        y = z.y_eq + z.H @ nu + np.diag(z.G_v) * rng.uniform(-1, 1, 16)
        py.step(du, y, available(k))
        c.step(du, y, available(k))
        assert np.all(np.abs(nu - c.c) <= c.hull * (1 + 1e-9) + 1e-12)
        if k > 200:
            widths_py.append(py.hull[:3].mean())
            widths_c.append(c.hull[:3].mean())
    assert np.mean(widths_c) == pytest.approx(np.mean(widths_py), rel=0.03)


def test_c_lkf_equals_the_python_reference_for_3000_steps(model, c_library):
    s = lkf_setup()
    rng = np.random.default_rng(9)
    K = lqr_gain(model)
    args = (model.A, model.B, s.H, s.Pw, s.Pv, np.zeros(23), s.P0)
    py, c = KalmanFilter(*args), c_estimators.CKalmanFilter(c_library, *args)
    nu, Lw = np.zeros(23), np.linalg.cholesky(s.Pw)
    worst = 0.0
    for k in range(3000):
        du = -K @ py.nu[:20]
        nu = model.A @ nu + model.B @ du + Lw @ rng.normal(size=23)
        dy = s.H @ nu + np.sqrt(np.diag(s.Pv)) * rng.normal(size=10)
        if k % 97 == 0:
            dy[k % 10] = np.nan  # a skipped entry now and then
        assert py.step(du, dy) == c.step(du, dy)
        worst = max(worst, np.abs(py.nu - c.nu).max(), np.abs(py.P - c.P).max())
    assert worst <= 1e-10, worst

"""Tests of the applications in adaptid.constrained: piecewise polynomials,
LQ control and LQ state estimation (Boyd & Vandenberghe (2018), §16.1.1,
§17.2, §17.3; the worked examples of shared/seeds/constrained-least-squares.ja.txt).

Oracles: scipy.interpolate.make_lsq_spline, numpy.polyfit, the reference's
own KKT method re-implemented here, cvxpy, matrix powers.
"""

import numpy as np
import pytest
from scipy.interpolate import make_interp_spline, make_lsq_spline

from adaptid.constrained import (
    PiecewisePolynomial,
    lq_control,
    lq_estimate,
    lq_estimate_cv,
    open_loop,
    piecewise_polyfit,
)

# ------------------------------------------------------------------ data

def reference_fit_data(seed=0, M=70):
    """The reference's example: M points on each side of 0."""
    rng = np.random.default_rng(seed)
    x = np.concatenate([rng.random(M) - 1.0, rng.random(M)])
    return x, x**3 - x + 0.4 / (1.0 + 25.0 * x**2)


# The reference's LQ control example (seed document, function main of lqc).
A_LQ = np.array([[0.855, 1.161, 0.667], [0.015, 1.073, 0.053], [-0.084, 0.059, 1.022]])
B_LQ = np.array([-0.076, -0.139, 0.342])
C_LQ = np.array([0.218, -3.597, -1.683])
X_INIT = np.array([0.496, -0.745, 1.394])

# The reference's double integrator (LQ state estimation example).
I2, Z2 = np.eye(2), np.zeros((2, 2))
A_DI = np.block([[I2, I2], [Z2, I2]])
B_DI = np.vstack([Z2, I2])
C_DI = np.hstack([I2, Z2])


def di_measurements(T=100, seed=0):
    rng = np.random.default_rng(seed)
    s = np.linspace(0.0, 5.0, T)
    return np.column_stack([s, np.sin(s) + 0.5 * rng.random(T)])


CVX_TOL = dict(tol_gap_abs=1e-12, tol_gap_rel=1e-12, tol_feas=1e-12)

# ------------------------------------------------------- piecewise polynomials


@pytest.mark.parametrize("knots", [[-1.0, 0.0, 1.0], np.linspace(-1.0, 1.0, 7),
                                   [-1.0, -0.7, -0.1, 0.05, 0.5, 1.0]])
def test_cubic_c2_fit_is_scipy_lsq_spline(knots):
    x, y = reference_fit_data()
    knots = np.asarray(knots)
    fit = piecewise_polyfit(x, y, knots, degree=3, continuity=2)
    order = np.argsort(x)
    t = np.r_[[knots[0]] * 4, knots[1:-1], [knots[-1]] * 4]
    spline = make_lsq_spline(x[order], y[order], t, k=3)
    grid = np.linspace(-1.0, 1.0, 1001)
    # Both are the exact LS solution over the same function space; the
    # problems are well conditioned (B-spline and scaled-power bases), so
    # they agree to rounding (~1e-15 observed).
    np.testing.assert_allclose(fit(grid), spline(grid), rtol=0, atol=1e-10)
    np.testing.assert_allclose(fit.rss, np.sum((spline(x) - y) ** 2), rtol=1e-9)


def left_right_derivatives(fit, i, k):
    """k-th derivative at knot i+1 from the left piece and from the right piece."""
    c = fit.coefficients
    h = fit.knots[i + 1] - fit.knots[i]
    j = np.arange(c.shape[1])
    fall = np.array([np.prod(np.arange(jj - k + 1, jj + 1)) if jj >= k else 0 for jj in j])
    left = np.sum(c[i] * fall * h ** np.maximum(j - k, 0) * (j >= k))
    right = c[i + 1, k] * np.prod(np.arange(1, k + 1))
    return left, right


def test_continuity_one_has_equal_value_and_slope_and_no_larger_residual():
    x, y = reference_fit_data()
    knots = np.linspace(-1.0, 1.0, 5)
    c1 = piecewise_polyfit(x, y, knots, degree=3, continuity=1)
    c2 = piecewise_polyfit(x, y, knots, degree=3, continuity=2)
    for i in range(3):
        for k in (0, 1):
            left, right = left_right_derivatives(c1, i, k)
            assert left == pytest.approx(right, abs=1e-12)   # exact constraint, O(1) values
    # continuity 1 is a weaker constraint: its space contains continuity 2's
    assert c1.rss <= c2.rss * (1 + 1e-12)
    curv = [left_right_derivatives(c1, i, 2) for i in range(3)]
    assert max(abs(a - b) for a, b in curv) > 1e-3      # C¹ but not C²


def test_two_cubics_equal_the_reference_kkt_method():
    # The reference's Julia code: global Vandermonde blocks, C rows for value
    # and slope at 0, KKT system with the Gram matrix.
    x, y = reference_fit_data(seed=5)
    left, right = x < 0, x >= 0
    V = lambda t: t[:, None] ** np.arange(4)  # noqa: E731
    A = np.zeros((x.size, 8))
    A[left, :4] = V(x[left])
    A[right, 4:] = V(x[right])
    C = np.array([[1, 0, 0, 0, -1, 0, 0, 0], [0, 1, 0, 0, 0, -1, 0, 0]], dtype=float)
    K = np.block([[2 * A.T @ A, C.T], [C, np.zeros((2, 2))]])
    theta = np.linalg.solve(K, np.concatenate([2 * A.T @ y, np.zeros(2)]))[:8]
    fit = piecewise_polyfit(x, y, [-1.0, 0.0, 1.0], degree=3, continuity=1)
    grid = np.linspace(-1, 1, 401)
    ref = np.where(grid < 0, V(grid) @ theta[:4], V(grid) @ theta[4:])
    # Gram condition number ~1e3 here: the reference's route is good to ~1e-13
    np.testing.assert_allclose(fit(grid), ref, atol=1e-10)
    # the right piece has local coefficients = global ones (its knot is 0)
    np.testing.assert_allclose(fit.coefficients[1], theta[4:], atol=1e-10)


def test_no_continuity_is_independent_polyfits():
    x, y = reference_fit_data(seed=2)
    knots = np.array([-1.0, -0.3, 0.4, 1.0])
    fit = piecewise_polyfit(x, y, knots, degree=2, continuity=-1)
    for i in range(3):
        sel = (x >= knots[i]) & (x < knots[i + 1]) if i < 2 else (x >= knots[i])
        ref = np.polynomial.Polynomial.fit(x[sel] - knots[i], y[sel], 2).convert().coef
        np.testing.assert_allclose(fit.coefficients[i], ref, atol=1e-10)  # O(1) coefficients


def test_degree_zero_continuity_zero_is_the_mean():
    x, y = reference_fit_data(seed=3)
    fit = piecewise_polyfit(x, y, [-1, 0.2, 1], degree=0, continuity=0)
    np.testing.assert_allclose(fit.coefficients[:, 0], np.mean(y), rtol=1e-13)


def test_exact_spline_data_are_reproduced_with_derivatives():
    rng = np.random.default_rng(4)
    knots = np.array([0.0, 1.0, 2.5, 3.0, 5.0])
    truth = make_interp_spline(np.linspace(0, 5, 9), rng.standard_normal(9), k=3)
    truth = make_lsq_spline(np.linspace(0, 5, 40), truth(np.linspace(0, 5, 40)),
                            np.r_[[0.0] * 4, knots[1:-1], [5.0] * 4], k=3)
    x = rng.uniform(0, 5, 60)
    fit = piecewise_polyfit(x, truth(x), knots, degree=3, continuity=2)
    grid = np.linspace(0, 5, 301)
    # noise-free data in the model space: exact to rounding (values O(1-10))
    for k in range(4):
        np.testing.assert_allclose(fit.derivative(k)(grid), truth.derivative(k)(grid)
                                   if k else truth(grid), atol=1e-8)
        np.testing.assert_allclose(fit(grid, k), fit.derivative(k)(grid), atol=1e-12)
    assert fit.derivative(4)(grid).max() == 0.0 and fit.derivative(2).degree == 1
    np.testing.assert_allclose(fit.to_ppoly()(grid), fit(grid), atol=1e-12)
    assert fit.derivative(1).continuity == 1


@pytest.mark.parametrize("kwargs, exc, pattern", [
    (dict(x=np.array([-2.0, 0.5]), y=np.ones(2)), ValueError,
     r"^x must be inside \[knots\[0\], knots\[-1\]\]"),
    (dict(knots=[1.0, 0.0]), ValueError, r"^knots must be strictly increasing"),
    (dict(continuity=4), ValueError, r"^continuity must be an integer <= 3"),
    (dict(degree=2.5), TypeError, r"^degree must be an integer"),
    (dict(y=np.ones(3)), ValueError, r"^y must be of shape \(140,\)"),
    (dict(x=np.linspace(-1, -0.5, 5), y=np.ones(5)), ValueError,
     r"^x must be spread over the intervals"),
    (dict(y=np.full(140, np.nan)), ValueError, r"^y must be finite"),
])
def test_piecewise_bad_input(kwargs, exc, pattern):
    x, y = reference_fit_data()
    args = dict(x=x, y=y, knots=[-1.0, 0.0, 1.0], degree=3, continuity=1)
    args.update(kwargs)
    with pytest.raises(exc, match=pattern):
        piecewise_polyfit(**args)


def test_piecewise_polynomial_object():
    p = PiecewisePolynomial([0.0, 1.0, 3.0], [[1.0, 2.0], [3.0, -1.0]], continuity=0)
    # p = 1 + 2x on [0, 1), 3 − (x − 1) on [1, 3]; extrapolated outside
    np.testing.assert_allclose(p([0.0, 0.5, 1.0, 2.0, 4.0, -1.0]), [1, 2, 3, 2, 0, -1])
    assert repr(p).startswith("PiecewisePolynomial(degree=1, continuity=0, intervals=2")
    with pytest.raises(ValueError, match=r"^coefficients must be of shape \(2, degree \+ 1\)"):
        PiecewisePolynomial([0.0, 1.0, 3.0], [[1.0, 2.0]])


# ------------------------------------------------------------------ LQ control

def cvxpy_lq_control(A, B, C, x_init, x_des, T, rho):
    import cvxpy as cp
    n, m = A.shape[0], B.shape[1]
    X, U = cp.Variable((n, T)), cp.Variable((m, T - 1))
    cons = [X[:, 1:] == A @ X[:, :-1] + B @ U, X[:, 0] == x_init, X[:, -1] == x_des]
    prob = cp.Problem(cp.Minimize(cp.sum_squares(C @ X) + rho * cp.sum_squares(U)), cons)
    prob.solve(solver="CLARABEL", **CVX_TOL)
    return X.value.T, U.value.T, prob.value


def test_lq_control_reference_example_matches_cvxpy_and_reaches_target():
    T, rho = 100, 0.2
    res = lq_control(A_LQ, B_LQ, C_LQ, X_INIT, np.zeros(3), T, rho)
    assert res.x.shape == (T, 3) and res.u.shape == (T - 1, 1) and res.y.shape == (T, 1)
    # end points are constraints of the exact QR solve: rounding level
    np.testing.assert_allclose(res.x[0], X_INIT, atol=1e-13)
    np.testing.assert_allclose(res.x[-1], 0.0, atol=1e-12)
    x, u, val = cvxpy_lq_control(A_LQ, B_LQ[:, None], C_LQ[None, :], X_INIT, np.zeros(3), T, rho)
    # cvxpy/Clarabel at 1e-12 tolerances is good to ~1e-9; the issue asks 1e-6
    np.testing.assert_allclose(res.x, x, atol=1e-6)
    np.testing.assert_allclose(res.u, u, atol=1e-6)
    np.testing.assert_allclose(res.cost, val, rtol=1e-8)
    np.testing.assert_allclose(res.cost, res.j_out + rho * res.j_in, rtol=1e-14)
    np.testing.assert_allclose(res.y[:, 0], res.x @ C_LQ, atol=1e-14)
    # dynamics hold along the trajectory
    resid = res.x[1:] - res.x[:-1] @ A_LQ.T - res.u @ B_LQ[None, :]
    assert np.max(np.abs(resid)) < 1e-12


def test_open_loop_does_not_reach_zero():
    T = 100
    ol = open_loop(A_LQ, C_LQ, X_INIT, T)
    x_T = np.linalg.matrix_power(A_LQ, T - 1) @ X_INIT
    np.testing.assert_allclose(ol.x[-1], x_T, rtol=1e-12)
    np.testing.assert_allclose(ol.y[-1, 0], C_LQ @ x_T, rtol=1e-12)
    # the reference's figure: the open-loop output ends near 0.1, not at 0
    assert abs(ol.y[-1, 0]) > 0.05


def test_lq_control_several_initial_states_at_once():
    inits = np.column_stack([X_INIT, -X_INIT, [1.0, 0.0, 0.0]])
    targets = np.column_stack([np.zeros(3), [0.1, 0.0, -0.1], np.zeros(3)])
    many = lq_control(A_LQ, B_LQ, C_LQ, inits, targets, 40, 0.5)
    assert many.x.shape == (40, 3, 3) and many.u.shape == (39, 1, 3) and many.cost.shape == (3,)
    for j in range(3):
        one = lq_control(A_LQ, B_LQ, C_LQ, inits[:, j], targets[:, j], 40, 0.5)
        # same factorisation, other right-hand side: equal to rounding
        np.testing.assert_allclose(many.x[..., j], one.x, atol=1e-12)
        np.testing.assert_allclose(many.u[..., j], one.u, atol=1e-11)
        np.testing.assert_allclose(many.x[-1, :, j], targets[:, j], atol=1e-12)
    # a single x_des is shared by every initial state
    shared = lq_control(A_LQ, B_LQ, C_LQ, inits, np.zeros(3), 40, 0.5)
    np.testing.assert_allclose(shared.x[..., 0], many.x[..., 0], atol=1e-12)


def test_lq_control_nonzero_target_matches_cvxpy():
    x_des = np.array([0.2, -0.1, 0.3])
    res = lq_control(A_LQ, B_LQ, C_LQ, X_INIT, x_des, 30, 1.0)
    x, u, _ = cvxpy_lq_control(A_LQ, B_LQ[:, None], C_LQ[None, :], X_INIT, x_des, 30, 1.0)
    np.testing.assert_allclose(res.x, x, atol=1e-6)   # as above
    np.testing.assert_allclose(res.u, u, atol=1e-6)


@pytest.mark.parametrize("kwargs, pattern", [
    (dict(B=np.zeros(3)), r"^T must be large enough .* for x_des to be reachable"),
    (dict(T=1), r"^T must be an integer >= 2"),
    (dict(rho=0.0), r"^rho must be in \(0.0, inf\]"),
    (dict(x_init=np.ones(2)), r"^x_init must be of shape \(3,\) or \(3, q\)"),
    (dict(x_des=np.ones((3, 2)), x_init=np.ones((3, 3))), r"^x_des must be of shape"),
    (dict(A=np.ones((3, 2))), r"^A must be a non-empty square matrix"),
    (dict(B=np.ones((2, 1))), r"^B must be of shape \(3, m\)"),
    (dict(C=np.ones(2)), r"^C must be of shape \(p, 3\)"),
    (dict(x_init=[np.nan, 0, 0]), r"^x_init must be finite"),
])
def test_lq_control_bad_input(kwargs, pattern):
    args = dict(A=A_LQ, B=B_LQ, C=C_LQ, x_init=X_INIT, x_des=np.zeros(3), T=20, rho=0.2)
    args.update(kwargs)
    with pytest.raises(ValueError, match=pattern):
        lq_control(**args)


# -------------------------------------------------------------- LQ estimation

def cvxpy_lq_estimate(A, B, C, y, lam):
    import cvxpy as cp
    T, n, m = y.shape[0], A.shape[0], B.shape[1]
    X, U = cp.Variable((n, T)), cp.Variable((m, T - 1))
    obs = ~np.isnan(y.T)
    resid = cp.multiply(obs.astype(float), np.nan_to_num(y.T) - C @ X)
    prob = cp.Problem(cp.Minimize(cp.sum_squares(resid) + lam * cp.sum_squares(U)),
                      [X[:, 1:] == A @ X[:, :-1] + B @ U])
    prob.solve(solver="CLARABEL", **CVX_TOL)
    return X.value.T, U.value.T, prob.value


def test_lq_estimate_reference_example_matches_cvxpy():
    y = di_measurements()
    res = lq_estimate(A_DI, B_DI, C_DI, y, 1e3)
    x, u, val = cvxpy_lq_estimate(A_DI, B_DI, C_DI, y, 1e3)
    # cvxpy/Clarabel at 1e-12 tolerances; states are O(5)
    np.testing.assert_allclose(res.x, x, atol=1e-6)
    np.testing.assert_allclose(res.u, u, atol=1e-6)
    np.testing.assert_allclose(res.cost, val, rtol=1e-8)
    np.testing.assert_allclose(res.y, res.x @ C_DI.T, atol=1e-14)
    assert res.n_missing == 0


def test_lq_estimate_with_missing_measurements_matches_cvxpy():
    y = di_measurements(seed=1)
    y[10:25] = np.nan          # missing samples (rows of NaN)
    y[60, 1] = np.nan          # one missing entry
    res = lq_estimate(A_DI, B_DI, C_DI, y, 1e3)
    x, u, val = cvxpy_lq_estimate(A_DI, B_DI, C_DI, y, 1e3)
    np.testing.assert_allclose(res.x, x, atol=1e-6)   # as above
    np.testing.assert_allclose(res.u, u, atol=1e-6)
    np.testing.assert_allclose(res.cost, val, rtol=1e-8)
    assert res.n_missing == 31


def test_lq_estimate_bad_input():
    y = di_measurements()
    with pytest.raises(ValueError, match=r"^y must be of shape \(T, 2\)"):
        lq_estimate(A_DI, B_DI, C_DI, y[:, :1], 1.0)
    with pytest.raises(ValueError, match=r"^y must be free of infinite values"):
        lq_estimate(A_DI, B_DI, C_DI, np.where(y > 1.2, np.inf, y), 1.0)
    with pytest.raises(ValueError, match=r"^y must be measured often enough"):
        lq_estimate(A_DI, B_DI, C_DI, np.full_like(y, np.nan), 1.0)
    with pytest.raises(ValueError, match=r"^lam must be in \(0.0, inf\]"):
        lq_estimate(A_DI, B_DI, C_DI, y, -1.0)
    with pytest.raises(ValueError, match=r"^B must be of shape \(4, m\)"):
        lq_estimate(A_DI, np.ones((3, 2)), C_DI, y, 1.0)


def test_lq_estimate_cv_curve_and_choice():
    y = di_measurements(T=60, seed=2)
    lams = np.logspace(0, 4, 5)
    cv = lq_estimate_cv(A_DI, B_DI, C_DI, y, lams, holdout=0.25, rng=7)
    assert cv.holdout.sum() == 15
    assert cv.lam == lams[np.argmin(cv.test_rms)]
    # the curve: held-out RMS of estimates that never saw the held-out rows
    y_train = y.copy()
    y_train[cv.holdout] = np.nan
    for lam, tr, te in zip(lams, cv.train_rms, cv.test_rms):
        est = lq_estimate(A_DI, B_DI, C_DI, y_train, lam)
        err = y - est.y
        assert te == pytest.approx(np.sqrt(np.mean(err[cv.holdout] ** 2)), rel=1e-10)
        assert tr == pytest.approx(np.sqrt(np.mean(err[~cv.holdout] ** 2)), rel=1e-10)
    # the training error grows with λ (a smoother fit)
    assert np.all(np.diff(cv.train_rms) > 0)
    full = lq_estimate(A_DI, B_DI, C_DI, y, cv.lam)
    np.testing.assert_allclose(cv.result.x, full.x, atol=1e-12)
    # explicit masks and indices give the same held-out set
    again = lq_estimate_cv(A_DI, B_DI, C_DI, y, lams, holdout=np.flatnonzero(cv.holdout))
    np.testing.assert_array_equal(again.holdout, cv.holdout)
    np.testing.assert_allclose(again.test_rms, cv.test_rms, rtol=1e-12)


def test_lq_estimate_cv_picks_a_lambda_near_the_noise_ratio():
    # Simulated double integrator: process noise σ_u = 0.01, measurement
    # noise σ_v = 0.1; the maximum a posteriori weight is (σ_v/σ_u)² = 100.
    rng = np.random.default_rng(3)
    T, su, sv = 80, 0.01, 0.1
    x = np.zeros((T, 4))
    x[0] = [0.0, 0.0, 0.05, 0.02]
    for t in range(T - 1):
        x[t + 1] = A_DI @ x[t] + B_DI @ (su * rng.standard_normal(2))
    y = x @ C_DI.T + sv * rng.standard_normal((T, 2))
    cv = lq_estimate_cv(A_DI, B_DI, C_DI, y, np.logspace(-1, 5, 7), rng=3)
    # validation is noisy (seeds 0-7 chose 10-1000); demand one decade
    assert 10.0 <= cv.lam <= 1e3


@pytest.mark.parametrize("holdout, exc, pattern", [
    (1.5, ValueError, r"^holdout must be in \(0.0, 1.0\)"),
    (0.001, ValueError, r"^holdout must be a fraction leaving"),
    (np.zeros(60, dtype=bool), ValueError, r"^holdout must be leaving at least one"),
    (np.zeros(5, dtype=bool), ValueError, r"^holdout must be a boolean mask of shape \(60,\)"),
    ([70], ValueError, r"^holdout must be time indices in \[0, 60\)"),
    ("all", TypeError, r"^holdout must be a fraction, a boolean mask or integer indices"),
])
def test_lq_estimate_cv_bad_holdout(holdout, exc, pattern):
    y = di_measurements(T=60)
    with pytest.raises(exc, match=pattern):
        lq_estimate_cv(A_DI, B_DI, C_DI, y, [1.0, 10.0], holdout=holdout, rng=0)
    with pytest.raises(ValueError, match=r"^lams must be a non-empty array of positive"):
        lq_estimate_cv(A_DI, B_DI, C_DI, y, [1.0, 0.0])


def test_results_have_useful_reprs():
    res = lq_control(A_LQ, B_LQ, C_LQ, X_INIT, np.zeros(3), 10, 0.2)
    assert repr(res).startswith("LQControlResult(T=10, x: 10x3, u: 9x1, rho=0.2, cost=")
    assert repr(open_loop(A_LQ, C_LQ, X_INIT, 5)).startswith("OpenLoopResult(T=5")
    est = lq_estimate(A_DI, B_DI, C_DI, di_measurements(T=20), 10.0)
    assert repr(est).startswith("LQEstimateResult(T=20, n=4, lam=10, cost=")

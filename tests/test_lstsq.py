"""Batch least squares against statsmodels and against the normal equations."""

import numpy as np
import pytest

import adaptid


def test_lstsq_equals_statsmodels_ols_and_wls(rng):
    import statsmodels.api as sm
    N, n = 200, 4
    X = np.column_stack([np.ones(N), rng.standard_normal((N, n - 1))])
    y = X @ [1.0, 2.0, -1.0, 0.5] + 0.3 * rng.standard_normal(N)
    res = adaptid.lstsq(X, y)
    ref = sm.OLS(y, X).fit()
    # 1e-10: both are QR-class solvers of the same well-conditioned problem
    np.testing.assert_allclose(res.theta, ref.params, rtol=1e-10)
    np.testing.assert_allclose(res.stderr, ref.bse, rtol=1e-10)
    np.testing.assert_allclose(res.sigma2, ref.scale, rtol=1e-10)
    np.testing.assert_allclose(res.conf_int(0.05), ref.conf_int(0.05), rtol=1e-10)
    w = rng.uniform(0.2, 3.0, N)
    res_w = adaptid.lstsq(X, y, weights=w)
    ref_w = sm.WLS(y, X, weights=w).fit()
    np.testing.assert_allclose(res_w.theta, ref_w.params, rtol=1e-10)
    np.testing.assert_allclose(res_w.stderr, ref_w.bse, rtol=1e-10)
    np.testing.assert_allclose(res_w.cov, ref_w.cov_params(), rtol=1e-10)


def test_lstsq_ridge_closed_form(rng):
    X = rng.standard_normal((30, 3))
    y = rng.standard_normal(30)
    res = adaptid.lstsq(X, y, ridge=2.5)
    closed = np.linalg.solve(X.T @ X + 2.5 * np.eye(3), X.T @ y)   # tiny, well conditioned
    np.testing.assert_allclose(res.theta, closed, rtol=1e-12)
    np.testing.assert_allclose(res.unscaled_cov, np.linalg.inv(X.T @ X + 2.5 * np.eye(3)), rtol=1e-12)


def test_lstsq_multi_output(rng):
    X = rng.standard_normal((50, 3))
    Y = rng.standard_normal((50, 2))
    res = adaptid.lstsq(X, Y)
    for j in range(2):
        r1 = adaptid.lstsq(X, Y[:, j])
        np.testing.assert_allclose(res.theta[:, j], r1.theta, rtol=1e-13)
        np.testing.assert_allclose(res.stderr[:, j], r1.stderr, rtol=1e-13)


def test_lstsq_ill_conditioned_keeps_digits(rng):
    """cond(Φ) = 1e8: QR keeps ~8 digits where the normal equations (cond 1e16) lose all."""
    N, n = 100, 4
    U, _ = np.linalg.qr(rng.standard_normal((N, n)))
    V, _ = np.linalg.qr(rng.standard_normal((n, n)))
    X = U @ np.diag([1.0, 1e-3, 1e-6, 1e-8]) @ V.T
    theta = np.array([1.0, -2.0, 3.0, 0.5])
    y = X @ theta       # consistent: the exact solution is theta
    err_qr = np.max(np.abs(adaptid.lstsq(X, y).theta - theta))
    err_ne = np.max(np.abs(np.linalg.solve(X.T @ X, X.T @ y) - theta))
    assert np.linalg.cond(X) == pytest.approx(1e8, rel=1e-3)
    assert err_qr < 1e-6          # ~ cond · eps = 1e-8, with margin
    assert err_ne > 1e-3          # the normal equations lose most digits
    assert err_ne > 1e3 * err_qr


@pytest.mark.parametrize("call,name", [
    (lambda: adaptid.lstsq(np.ones(5), np.ones(5)), "Phi"),
    (lambda: adaptid.lstsq(np.ones((5, 2)), np.ones(4)), "y"),
    (lambda: adaptid.lstsq(np.full((5, 2), np.nan), np.ones(5)), "Phi"),
    (lambda: adaptid.lstsq(np.ones((5, 2)), np.ones(5), weights=-np.ones(5)), "weights"),
    (lambda: adaptid.lstsq(np.ones((5, 2)), np.ones(5), ridge=-1.0), "ridge"),
    (lambda: adaptid.lstsq(np.ones((5, 2)), np.ones(5)), "rank"),
])
def test_lstsq_bad_input(call, name):
    with pytest.raises(ValueError, match=name):
        call()

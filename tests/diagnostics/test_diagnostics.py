"""Tests of adaptid.diagnostics against statsmodels, a slow oracle and theory."""

import importlib

import numpy as np
import pytest
from scipy.stats import chi2, norm

import adaptid
from adaptid.diagnostics import (
    autocorrelation_test,
    cross_correlation_test,
    cusum,
    cusum_squares,
    fit_percent,
    recursive_residuals,
)
from adaptid._kernels.layers._residuals import recursive_residuals_kernel


# --------------------------------------------------------------------------
# slow, obviously correct oracles
# --------------------------------------------------------------------------
def naive_recursive_residuals(Phi, y, start=None):
    """w_k by the textbook formula: one lstsq and one solve per sample."""
    N, n = Phi.shape
    start = n if start is None else start
    w = []
    for k in range(start, N):  # k = number of samples used for theta_{k-1}
        A = Phi[:k]
        theta = np.linalg.lstsq(A, y[:k], rcond=None)[0]
        f = 1.0 + Phi[k] @ np.linalg.solve(A.T @ A, Phi[k])
        w.append((y[k] - Phi[k] @ theta) / np.sqrt(f))
    return np.array(w)


@pytest.fixture(scope="module")
def macro():
    """statsmodels' macrodata regression: cpi on const + m1 (N = 203, n = 2)."""
    import statsmodels.api as sm   # a declared test dependency: fail, never skip
    from statsmodels.regression.recursive_ls import RecursiveLS

    data = sm.datasets.macrodata.load_pandas().data
    X = np.column_stack([np.ones(len(data)), data["m1"].to_numpy()])
    y = data["cpi"].to_numpy()
    res = RecursiveLS(y, X).fit()
    return X, y, res


# --------------------------------------------------------------------------
# recursive residuals
# --------------------------------------------------------------------------
@pytest.mark.parametrize("n", [1, 3, 6])
def test_recursive_residuals_match_naive_oracle(n):
    rng = np.random.default_rng(n)
    N = 80
    Phi = rng.standard_normal((N, n)) * np.logspace(0, 2, n)  # unequal column scales
    y = Phi @ rng.standard_normal(n) + 0.3 * rng.standard_normal(N)
    w = recursive_residuals(Phi, y)
    assert w.shape == (N - n,)
    # both are backward stable on data of condition ~1e2: agreement to ~1e-12
    np.testing.assert_allclose(w, naive_recursive_residuals(Phi, y), rtol=1e-10, atol=1e-12)


def test_recursive_residuals_sum_of_squares_is_ols_ssr():
    # BDE (1975) Lemma 1 consequence: sum of w_k^2 = full-sample OLS SSR
    rng = np.random.default_rng(7)
    Phi = rng.standard_normal((500, 4))
    y = Phi @ [1.0, 2.0, -1.0, 0.5] + rng.standard_normal(500)
    w = recursive_residuals(Phi, y)
    r = y - Phi @ np.linalg.lstsq(Phi, y, rcond=None)[0]
    assert w @ w == pytest.approx(r @ r, rel=1e-12)


def test_recursive_residuals_match_statsmodels(macro):
    X, y, res = macro
    w = recursive_residuals(X, y)
    k = X.shape[1]
    # statsmodels runs a Kalman filter from a diffuse prior; agreement is
    # limited by that start to ~1e-10 relative (observed 1.5e-10)
    np.testing.assert_allclose(w, res.resid_recursive[k:], rtol=1e-8, atol=1e-8 * np.abs(w).max())
    np.testing.assert_allclose(w, naive_recursive_residuals(X, y), rtol=1e-11, atol=1e-11)


def test_compiled_kernel_equals_python_source():
    # compiled equals the kernel's own Python source (as NUMBA_DISABLE_JIT=1 runs it)
    rng = np.random.default_rng(3)
    Phi = rng.standard_normal((40, 3))
    y = rng.standard_normal(40)
    tol = np.zeros(3)
    out = []
    # (under NUMBA_DISABLE_JIT=1 the kernel is its own Python source)
    py_func = getattr(recursive_residuals_kernel, "py_func", recursive_residuals_kernel)
    for fn in (recursive_residuals_kernel, py_func):
        R, w = np.zeros((3, 4)), np.empty(37)
        assert fn(Phi, y, tol, R, w) == 0
        out.append((R, w))
    np.testing.assert_allclose(out[0][1], out[1][1], rtol=1e-13, atol=1e-14)
    np.testing.assert_allclose(out[0][0], out[1][0], rtol=1e-13, atol=1e-14)


def test_rank_deficient_start_gives_nan_and_warning():
    rng = np.random.default_rng(11)
    N, n = 60, 3
    Phi = rng.standard_normal((N, n))
    Phi[:5, 2] = 0.0            # third regressor silent for the first 5 samples
    y = rng.standard_normal(N)
    with pytest.warns(adaptid.ExcitationWarning, match="first 6 rows"):
        w = recursive_residuals(Phi, y)
    # w_k is defined once Phi_{k-1} has rank 3, i.e. from k - 1 = 6 on
    assert np.isnan(w[:3]).all()
    np.testing.assert_allclose(w[3:], naive_recursive_residuals(Phi, y, start=6),
                               rtol=1e-10, atol=1e-12)


def test_rank_deficient_everywhere_raises():
    Phi = np.ones((20, 2))
    with pytest.raises(ValueError, match="Phi must be of full column rank"):
        recursive_residuals(Phi, np.arange(20.0))


@pytest.mark.parametrize("Phi, y, exc, match", [
    (np.ones((5, 2)), np.ones(4), ValueError, r"y must be of shape \(5,\)"),
    (np.ones((2, 2)), np.ones(2), ValueError, "Phi must be taller than wide"),
    (np.ones(5), np.ones(5), ValueError, "Phi must be 2-dimensional"),
    (np.full((5, 2), np.nan), np.ones(5), ValueError, "Phi must be finite"),
    ([["a", "b"]] * 5, np.ones(5), TypeError, "Phi must be a real numeric array"),
])
def test_recursive_residuals_argument_errors(Phi, y, exc, match):
    with pytest.raises(exc, match=match):
        recursive_residuals(Phi, y)


# --------------------------------------------------------------------------
# CUSUM and CUSUM of squares
# --------------------------------------------------------------------------
def test_cusum_std_convention_equals_statsmodels(macro):
    X, y, res = macro
    N, k = X.shape
    w = recursive_residuals(X, y)
    points = np.arange(k + 1, N + 1)       # sample r of each statistic entry
    for alpha in (0.05, 0.01):
        c = cusum(w, alpha, scale="std")
        # statistic: rel. agreement limited by statsmodels' diffuse start (see above)
        np.testing.assert_allclose(c.statistic, res.cusum, rtol=1e-8, atol=1e-8)
        lo, up = res._cusum_significance_bounds(alpha, points=points)
        np.testing.assert_allclose(c.lower, lo, rtol=1e-14)   # same closed form
        np.testing.assert_allclose(c.upper, up, rtol=1e-14)
        outside = (res.cusum < lo) | (res.cusum > up)
        assert c.crossed == outside.any()
        assert c.first_crossing == np.flatnonzero(outside)[0]


def test_cusum_default_scale_is_recursive_residuals_std(macro):
    # issue 17: the default divides by sd(w) (ddof=1) as R strucchange
    # efp("Rec-CUSUM"), Stata cusum6 and statsmodels RecursiveLS.cusum do.
    X, y, res = macro
    w = recursive_residuals(X, y)
    c = cusum(w)
    assert c.scale == pytest.approx(np.std(naive_recursive_residuals(X, y), ddof=1), rel=1e-10)
    np.testing.assert_allclose(c.statistic, res.cusum, rtol=1e-8, atol=1e-8)


def test_cusum_ols_scale_is_brown_durbin_evans_normalisation(macro):
    X, y, _ = macro
    N, n = X.shape
    w = recursive_residuals(X, y)
    c = cusum(w, scale="ols")
    # BDE: sigma_hat^2 = S_T / (T - k), S_T the full-sample OLS residual SS
    r = y - X @ np.linalg.lstsq(X, y, rcond=None)[0]
    sigma = np.sqrt(r @ r / (N - n))
    assert c.scale == pytest.approx(sigma, rel=1e-12)
    np.testing.assert_allclose(c.statistic, np.cumsum(naive_recursive_residuals(X, y)) / sigma,
                               rtol=1e-10, atol=1e-10)
    j = np.arange(1, N - n + 1)
    m = N - n
    np.testing.assert_allclose(c.upper, 0.948 * np.sqrt(m) + 2 * 0.948 * j / np.sqrt(m), rtol=1e-15)
    assert c.crossed  # the cpi ~ m1 relation is notoriously unstable


def test_cusum_known_scale():
    w = np.array([1.0, -2.0, 0.5, 3.0])
    c = cusum(w, scale=2.0)
    np.testing.assert_allclose(c.statistic, np.cumsum(w) / 2.0)


@pytest.mark.parametrize("alpha, a", [(0.10, 0.850), (0.05, 0.948), (0.01, 1.143)])
def test_cusum_critical_values_solve_bde_crossing_equation(alpha, a):
    # BDE (1975) p. 154 prints a to 3 decimals; they solve
    # Q(3a) + exp(-4a^2) Phi(a) = alpha/2 to that accuracy.
    # (statsmodels uses 0.950 for alpha = 0.10, a misprint: this equation gives 0.8499.)
    c = cusum(np.random.default_rng(0).standard_normal(50), alpha)
    assert c.critical_value == a
    p = norm.sf(3 * a) + np.exp(-4 * a * a) * norm.cdf(a)
    assert p == pytest.approx(alpha / 2, rel=2e-3)


def test_cusum_untabulated_alpha_solves_equation():
    for alpha in (0.02, 0.2, 0.5):
        a = cusum(np.ones(10) + np.arange(10), alpha).critical_value
        p = norm.sf(3 * a) + np.exp(-4 * a * a) * norm.cdf(a)
        assert p == pytest.approx(alpha / 2, rel=1e-10)
    a_values = [cusum(np.arange(1.0, 11.0), al).critical_value for al in (0.011, 0.049, 0.099)]
    assert a_values[0] > a_values[1] > a_values[2]   # stricter level, wider band


def test_cusum_squares_equals_statsmodels(macro):
    X, y, res = macro
    N, k = X.shape
    w = recursive_residuals(X, y)
    points = np.arange(k + 1, N + 1)
    for alpha in (0.2, 0.1, 0.05, 0.02, 0.01):
        cs = cusum_squares(w, alpha)
        np.testing.assert_allclose(cs.statistic, res.cusum_squares, rtol=1e-9, atol=1e-12)
        lo, up = res._cusum_squares_significance_bounds(alpha, points=points)
        np.testing.assert_allclose(cs.lower, lo, rtol=1e-13, atol=1e-15)
        np.testing.assert_allclose(cs.upper, up, rtol=1e-13, atol=1e-15)
        outside = (res.cusum_squares < lo) | (res.cusum_squares > up)
        assert cs.crossed == outside.any()
        assert cs.first_crossing == np.flatnonzero(outside)[0]


def test_cusum_squares_statistic_against_oracle():
    rng = np.random.default_rng(5)
    w = rng.standard_normal(30)
    cs = cusum_squares(w)
    expected = np.array([np.sum(w[:j] ** 2) for j in range(1, 31)]) / np.sum(w**2)
    np.testing.assert_allclose(cs.statistic, expected, rtol=1e-14)
    assert cs.statistic[-1] == 1.0


def test_size_under_constant_parameters_and_power_after_a_break():
    """Monte Carlo: rejection rates against the nominal 5 % level."""
    rng = np.random.default_rng(2024)
    R, N = 2000, 200
    n_cusum = n_sq = 0
    for _ in range(R):
        X = np.column_stack([np.ones(N), rng.standard_normal(N)])
        y = X @ [1.0, 2.0] + rng.standard_normal(N)
        w = recursive_residuals(X, y)
        n_cusum += cusum(w).crossed
        n_sq += cusum_squares(w).crossed
    se = np.sqrt(0.05 * 0.95 / R)   # binomial standard error, 0.0049
    # the BDE line bounds are conservative in finite samples (size ~0.035 here)
    assert 0.015 < n_cusum / R < 0.05 + 4 * se
    # Edgerton-Wells critical values are accurate to about 1 % of size at m ~ 200
    assert abs(n_sq / R - 0.05) < 4 * se

    # power: a mean shift of 1.5 sigma at 60 % of the sample is detected
    X = np.column_stack([np.ones(N), rng.standard_normal(N)])
    y = X @ [1.0, 2.0] + rng.standard_normal(N)
    y[120:] += 1.5
    c = cusum(recursive_residuals(X, y))
    assert c.crossed and c.first_crossing >= 120 - 2


@pytest.mark.parametrize("call, exc, match", [
    (lambda: cusum(np.ones(5), 1.5), ValueError, r"alpha must be in \(0.0, 1.0\)"),
    (lambda: cusum(np.ones(5), "x"), TypeError, "alpha must be a real number"),
    (lambda: cusum(np.ones(5), scale="harvey"), ValueError, "scale must be one of 'ols', 'std'"),
    (lambda: cusum(np.ones(5), scale=-1.0), ValueError, r"scale must be in \(0.0, inf\]"),
    (lambda: cusum(np.ones(5), scale=[1.0]), TypeError, "scale must be 'ols', 'std' or a positive float"),
    (lambda: cusum(np.zeros(5)), ValueError, "w must be not identically zero"),
    (lambda: cusum([1.0]), ValueError, "w must be at least 2 recursive residuals long"),
    (lambda: cusum([1.0, np.nan]), ValueError, "w must be finite"),
    (lambda: cusum_squares(np.ones(5), 0.03), ValueError,
     "alpha must be one of 0.2, 0.1, 0.05, 0.02, 0.01"),
    (lambda: cusum_squares(np.ones(2)), ValueError, "w must be at least 3"),
])
def test_cusum_argument_errors(call, exc, match):
    with pytest.raises(exc, match=match):
        call()


def test_cusum_result_plot(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    w = np.random.default_rng(0).standard_normal(40)
    fig = cusum(w).plot()
    ax = fig.axes[0]
    assert len(ax.lines) == 3
    assert cusum_squares(w).plot(ax=ax, x=np.arange(3, 43)) is fig
    fig.savefig(tmp_path / "c.png")
    import matplotlib.pyplot as plt

    plt.close("all")


# --------------------------------------------------------------------------
# whiteness and cross-correlation
# --------------------------------------------------------------------------
def test_autocorrelation_equals_statsmodels():
    from statsmodels.stats.diagnostic import acorr_ljungbox
    from statsmodels.tsa.stattools import acf

    rng = np.random.default_rng(9)
    e = np.convolve(rng.standard_normal(400), [1.0, 0.4], mode="same") + 2.0
    r = autocorrelation_test(e, max_lag=15, ddof=2)
    np.testing.assert_allclose(r.acf, acf(e, nlags=15, adjusted=False, fft=False), rtol=1e-12, atol=1e-14)
    lb = acorr_ljungbox(e, lags=[15], model_df=2)
    assert r.q_stat == pytest.approx(lb["lb_stat"].iloc[0], rel=1e-12)
    assert r.p_value == pytest.approx(lb["lb_pvalue"].iloc[0], rel=1e-9)
    assert r.dof == 13
    assert r.band == pytest.approx(1.959963984540054 / 20.0, rel=1e-12)
    assert not r.white          # MA(1) with coefficient 0.4, N = 400
    assert r.outside[1] and not r.outside[0]


def test_autocorrelation_white_noise_level():
    # the Ljung-Box p-value of white noise is uniform: check the rejection
    # rate over many series (binomial se 0.007 at R = 1000)
    rng = np.random.default_rng(1)
    rejections = sum(not autocorrelation_test(rng.standard_normal(500), 10).white for _ in range(1000))
    assert abs(rejections / 1000 - 0.05) < 0.025


def test_cross_correlation_against_oracle_and_statsmodels():
    from statsmodels.tsa.stattools import ccf

    rng = np.random.default_rng(4)
    N, M = 300, 8
    u = rng.standard_normal(N).cumsum() * 0.1 + rng.standard_normal(N)
    e = 0.4 * np.roll(u, 2) + rng.standard_normal(N)
    r = cross_correlation_test(u, e, max_lag=M, alpha=0.01)
    uc, ec = u - u.mean(), e - e.mean()
    den = np.sqrt((uc @ uc) * (ec @ ec))
    oracle = []
    for tau in range(-M, M + 1):
        oracle.append(sum(ec[t] * uc[t - tau] for t in range(N) if 0 <= t - tau < N) / den)
    np.testing.assert_allclose(r.ccf, oracle, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(r.ccf[M:], ccf(e, u, adjusted=False, fft=False)[:M + 1], atol=1e-14)
    np.testing.assert_allclose(r.ccf[:M + 1][::-1], ccf(u, e, adjusted=False, fft=False)[:M + 1], atol=1e-14)
    np.testing.assert_array_equal(r.lags, np.arange(-M, M + 1))
    q = N * np.sum(np.asarray(oracle[M:]) ** 2)
    assert r.q_stat == pytest.approx(q, rel=1e-12)
    assert r.p_value == pytest.approx(chi2.sf(q, M + 1), rel=1e-9)
    assert r.band == pytest.approx(norm.ppf(0.995) / np.sqrt(N), rel=1e-12)
    assert r.outside[M + 2] and not r.independent


@pytest.mark.parametrize("call, exc, match", [
    (lambda: autocorrelation_test(np.ones(10)), ValueError, "e must be not constant"),
    (lambda: autocorrelation_test(np.arange(10.0), max_lag=10), ValueError, "max_lag must be an integer <= 9"),
    (lambda: autocorrelation_test(np.arange(10.0), max_lag=2.0), TypeError, "max_lag must be an integer"),
    (lambda: autocorrelation_test(np.arange(10.0), 3, ddof=3), ValueError, "ddof must be an integer <= 2"),
    (lambda: cross_correlation_test(np.arange(9.0), np.arange(10.0), 3), ValueError,
     r"u must be of the same length as e \(10\)"),
])
def test_whiteness_argument_errors(call, exc, match):
    with pytest.raises(exc, match=match):
        call()


def test_fit_percent():
    y = np.array([1.0, 3.0, 2.0, 5.0])
    y_hat = np.array([1.5, 2.5, 2.0, 4.0])
    expected = 100 * (1 - np.sqrt(0.25 + 0.25 + 0 + 1.0) / np.sqrt(np.sum((y - 2.75) ** 2)))
    assert fit_percent(y, y_hat) == pytest.approx(expected, rel=1e-14)
    both = fit_percent(np.column_stack([y, 2 * y]), np.column_stack([y_hat, np.full(4, 5.5)]))
    np.testing.assert_allclose(both, [expected, 0.0], atol=1e-12)
    with pytest.raises(ValueError, match=r"y_hat must be of shape \(4,\)"):
        fit_percent(y, y_hat[:3])


def test_public_names_do_not_leak():
    for modname in ("adaptid.diagnostics", "adaptid.datasets"):
        mod = importlib.import_module(modname)
        for name in mod.__all__:  # lazily provided names land in the namespace on first use
            getattr(mod, name)
        public = {k for k, v in vars(mod).items()
                  if not k.startswith("_") and not isinstance(v, type(importlib))}
        assert public == set(mod.__all__), modname

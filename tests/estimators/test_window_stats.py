"""run(..., stats=True): windowed statistics against statsmodels and numpy.

Oracles: statsmodels ``RollingOLS`` / ``RollingWLS`` (statsmodels/regression/
rolling.py, 0.14+), and direct (weighted, ridge) least squares solved here with
``numpy.linalg.lstsq``; neither shares code with the compiled recursion.

Tolerance. With a finite P0 the estimators carry a ridge prior (the tests
with ``P0="diffuse"`` at the end have none and use 1e-10): with ``P0 = 1e12``
and regressors of order 1 over windows of M ≥ 25
samples the prior changes θ, P and the statistics by about
1e-12 · ‖θ‖² / (M σ²) relative, i.e. 1e-12 … 1e-13. The recursion itself
adds and removes O(σ²) terms to sums of size M σ², so its rounding grows like
√N · ε · κ(Φ) (N ≤ 400, κ ≤ 10): ≈ 1e-13. Observed: ≤ 4e-12 relative.
RTOL = 1e-9 leaves three decades of margin and is still seven decades below
what a wrong formula gives (an off-by-one in nobs or the degrees of freedom
changes σ̂² by 1/M ≈ 3e-2). The likelihood is compared with an absolute
tolerance scaled by nobs (it is a sum of nobs terms, and crosses zero).
"""

import numpy as np
import pytest

import adaptid

import statsmodels.regression.rolling as sm_rolling  # noqa: E402 - the test extra installs it

RTOL = 1e-9
P0 = 1e12
FIELDS = ("ssr", "sigma2", "stderr", "tvalues", "rsquared", "rsquared_adj", "llf", "aic", "bic")
SM_NAME = {"sigma2": "mse_resid", "stderr": "bse"}


def _data(N=300, n=4, const=True, seed=0, p=None):
    rng = np.random.default_rng(seed)
    X = rng.standard_normal((N, n))
    if const:
        X[:, 0] = 1.0
    theta = np.array([1.0, -2.0, 0.5, 0.25, 1.5][:n])
    noise = 0.5 * rng.standard_normal((N,) if p is None else (N, p))
    y = X @ theta + noise if p is None else (X @ theta)[:, None] * [1.0, -0.5][:p] + noise
    return X, y


def _close(a, b, nobs=None, name=""):
    a, b = np.asarray(a, float), np.asarray(b, float)
    if name in ("llf", "aic", "bic"):  # sums of nobs log terms
        atol = RTOL * 10 * np.max(nobs)
        np.testing.assert_allclose(a, b, rtol=RTOL, atol=atol, err_msg=name)
    else:
        np.testing.assert_allclose(a, b, rtol=RTOL, atol=0.0, err_msg=name)


def _compare_rolling(stats, theta, res, rows):
    nobs = np.asarray(res.nobs)[rows]
    np.testing.assert_array_equal(stats.nobs[rows], nobs)
    _close(theta[rows], np.asarray(res.params)[rows], name="params")
    for f in FIELDS:
        _close(getattr(stats, f)[rows], np.asarray(getattr(res, SM_NAME.get(f, f)))[rows],
               nobs, f)


@pytest.mark.parametrize("const", [True, False])
def test_window_equals_rolling_ols(const):
    X, y = _data(const=const)
    M = 40
    tr = adaptid.SlidingWindowRLS(4, M, P0=P0).run(X, y, stats=True)
    assert tr.stats.k_constant == int(const)
    res = sm_rolling.RollingOLS(y, X, window=M).fit()
    assert res.k_constant == int(const)
    _compare_rolling(tr.stats, tr.theta, res, slice(M - 1, None))
    # the windows still filling up: statsmodels' expanding fit
    exp = sm_rolling.RollingOLS(y, X, window=M, expanding=True, min_nobs=6).fit()
    _compare_rolling(tr.stats, tr.theta, exp, slice(5, M))
    assert np.isnan(tr.stats.sigma2[:4]).all()  # n_eff <= n: no degrees of freedom


@pytest.mark.parametrize("const", [True, False])
def test_window_equals_rolling_wls(const):
    X, y = _data(const=const, seed=1)
    w = np.random.default_rng(2).uniform(0.2, 3.0, X.shape[0])
    M = 35
    tr = adaptid.SlidingWindowRLS(4, M, P0=P0).run(X, y, weights=w, stats=True)
    res = sm_rolling.RollingWLS(y, X, window=M, weights=w).fit()
    _compare_rolling(tr.stats, tr.theta, res, slice(M - 1, None))


def _direct(X, y, c, w, n, p0=P0, k_constant=1):
    """Weighted ridge LS of one window by lstsq: rows sqrt(c w) [X | y] and the prior rows."""
    sw = np.sqrt(c * w)
    prior = 1.0 / np.sqrt(p0)
    A = np.vstack([sw[:, None] * X, prior * np.eye(n)])
    b = np.concatenate([sw * y, np.zeros(n)])
    theta, *_ = np.linalg.lstsq(A, b, rcond=None)
    r = y - X @ theta
    ssr = np.sum(c * w * r * r) + np.sum((prior * theta) ** 2)
    n_eff = np.sum(c)
    sigma2 = ssr / (n_eff - n)
    Rq = np.linalg.qr(A, mode="r")
    Rinv = np.linalg.solve(Rq, np.eye(n))  # P = R^-1 R^-T
    se = np.sqrt(sigma2 * np.sum(Rinv ** 2, axis=1))
    cw = c * w
    ybar = np.sum(cw * y) / np.sum(cw)
    tss = np.sum(cw * (y - ybar) ** 2) if k_constant else np.sum(cw * y * y)
    llf = -0.5 * n_eff * (1 + np.log(2 * np.pi) + np.log(ssr / n_eff)) \
        + 0.5 * np.sum(c * np.log(w))
    return dict(theta=theta, ssr=ssr, sigma2=sigma2, stderr=se, tvalues=theta / se,
                rsquared=1 - ssr / tss,
                rsquared_adj=1 - (n_eff - k_constant) / (n_eff - n) * (ssr / tss),
                llf=llf, aic=-2 * llf + 2 * n, bic=-2 * llf + np.log(n_eff) * n, n_eff=n_eff)


def _check_direct(stats, theta, k, ref, nobs):
    assert stats.nobs[k] == nobs
    _close(stats.n_eff[k], ref["n_eff"], name="n_eff")
    _close(theta[k], ref["theta"], name="theta")
    for f in FIELDS:
        _close(getattr(stats, f)[k], ref[f], nobs, f)


def test_window_against_lstsq_of_each_window():
    X, y = _data(N=200, seed=3)
    w = np.random.default_rng(4).uniform(0.5, 2.0, 200)
    M = 30
    tr = adaptid.SlidingWindowRLS(4, M, P0=P0).run(X, y, weights=w, stats=True)
    for k in (10, 29, 30, 77, 150, 199):
        a = max(0, k + 1 - M)
        ref = _direct(X[a:k + 1], y[a:k + 1], np.ones(k + 1 - a), w[a:k + 1], 4)
        _check_direct(tr.stats, tr.theta, k, ref, k + 1 - a)


@pytest.mark.parametrize("lam", [0.97, 1.0])
def test_rls_against_weighted_lstsq_of_all_samples(lam):
    """RLS under forgetting: the data so far with weights λ^{k−i} w_i (and the
    decayed prior), σ̂² over Σλ^{k−i} − n as adaptid.recursive_fit_stats."""
    X, y = _data(N=250, seed=5)
    w = np.random.default_rng(6).uniform(0.5, 2.0, 250)
    est = adaptid.RLS(4, forgetting=lam, P0=P0)
    tr = est.run(X, y, weights=w, stats=True)
    for k in (8, 60, 249):
        c = lam ** np.arange(k, -1, -1.0)
        ref = _direct(X[:k + 1], y[:k + 1], c, w[:k + 1], 4, p0=P0 / lam ** (k + 1))
        _check_direct(tr.stats, tr.theta, k, ref, k + 1)
    fit = adaptid.recursive_fit_stats(est, X, y, weights=w)  # the one σ̂² rule
    _close(tr.stats.n_eff[-1], fit.n_eff, name="n_eff")
    _close(tr.stats.sigma2[-1], fit.sigma2, name="sigma2")
    _close(tr.stats.stderr[-1], fit.stderr, name="stderr")


def test_window_with_forgetting_against_lstsq():
    X, y = _data(N=120, seed=7)
    lam, M = 0.95, 25
    tr = adaptid.SlidingWindowRLS(4, M, forgetting=lam, P0=P0).run(X, y, stats=True)
    for k in (24, 80, 119):
        a = k + 1 - M
        c = lam ** np.arange(M - 1, -1, -1.0)
        ref = _direct(X[a:k + 1], y[a:k + 1], c, np.ones(M), 4, p0=P0 / lam ** (k + 1))
        _check_direct(tr.stats, tr.theta, k, ref, M)


def test_rebuild_path_gives_the_direct_values():
    """A window that loses excitation: column 3 is nonzero at sample 50 only; its
    removal at sample 50 + M would lose definiteness and the window is re-solved
    from its buffer (the statistics are then recomputed from the buffer)."""
    X, y = _data(N=140, seed=8)
    X[:, 3] = 0.0
    X[50, 3] = 1.0
    M = 30
    est = adaptid.SlidingWindowRLS(4, M, P0=P0)
    with pytest.warns(adaptid.DefinitenessLossWarning):
        tr = est.run(X, y, stats=True)
    assert tr.n_rebuilds >= 1
    for k in (79, 80, 81, 120, 139):
        a = k + 1 - M
        ref = _direct(X[a:k + 1], y[a:k + 1], np.ones(M), np.ones(M), 4)
        _check_direct(tr.stats, tr.theta, k, ref, M)


def test_several_outputs_are_rolling_ols_per_output():
    X, Y = _data(N=200, seed=9, p=2)
    M = 30
    tr = adaptid.SlidingWindowRLS(4, M, P0=P0, n_outputs=2).run(X, Y, stats=True)
    assert tr.stats.ssr.shape == (200, 2) and tr.stats.stderr.shape == (200, 4, 2)
    for j in range(2):
        res = sm_rolling.RollingOLS(Y[:, j], X, window=M).fit()
        st = tr.stats
        one = type(st)(**{f: (getattr(st, f)[..., j] if f not in ("nobs", "n_eff", "k_constant")
                              else getattr(st, f)) for f in st.__dataclass_fields__})
        _compare_rolling(one, tr.theta[..., j], res, slice(M - 1, None))


def test_rls_stats_continue_across_runs_and_refuse_a_gap():
    X, y = _data(N=100, seed=10)
    one = adaptid.RLS(4, forgetting=0.98, P0=P0).run(X, y, stats=True).stats
    est = adaptid.RLS(4, forgetting=0.98, P0=P0)
    a = est.run(X[:40], y[:40], stats=True).stats
    b = est.run(X[40:], y[40:], stats=True).stats
    for f in FIELDS:
        np.testing.assert_array_equal(np.concatenate([getattr(a, f), getattr(b, f)]),
                                      getattr(one, f))
    est.update(X[0], y[0])
    with pytest.raises(ValueError, match="reset"):
        est.run(X, y, stats=True)
    assert est.reset().run(X, y, stats=True).stats is not None


def test_window_stats_resume_from_the_buffer():
    X, y = _data(N=100, seed=11)
    one = adaptid.SlidingWindowRLS(4, 20, P0=P0).run(X, y, stats=True).stats
    est = adaptid.SlidingWindowRLS(4, 20, P0=P0)
    est.run(X[:55], y[:55])  # without statistics
    b = est.run(X[55:], y[55:], stats=True).stats
    for f in FIELDS:
        _close(getattr(b, f), getattr(one, f)[55:], 20, f)


def test_skipped_samples_leave_the_statistics_unchanged():
    X, y = _data(N=80, seed=12)
    Xn = np.insert(X, 40, np.nan, axis=0)
    yn = np.insert(y, 40, 0.0)
    ref = adaptid.SlidingWindowRLS(4, 20, P0=P0).run(X, y, stats=True).stats
    st = adaptid.SlidingWindowRLS(4, 20, P0=P0, nan_policy="skip").run(Xn, yn, stats=True).stats
    keep = np.r_[0:40, 41:81]
    for f in FIELDS:
        np.testing.assert_array_equal(getattr(st, f)[keep], getattr(ref, f))
        np.testing.assert_array_equal(getattr(st, f)[40], getattr(ref, f)[39])


@pytest.mark.parametrize("make", [lambda: adaptid.RLS(4, forgetting=0.99, P0=P0),
                                  lambda: adaptid.SlidingWindowRLS(4, 25, P0=P0)])
def test_batched_equals_one_stream_at_a_time(make):
    X, y = _data(N=90, seed=13)
    X2, y2 = _data(N=90, seed=14)
    tr = make().run_batched(np.stack([X, X2]), np.stack([y, y2]), stats=True)
    for b, (Xb, yb) in enumerate(((X, y), (X2, y2))):
        one = make().run(Xb, yb, stats=True).stats
        for f in FIELDS:
            np.testing.assert_array_equal(getattr(tr.stats, f)[b], getattr(one, f))


def test_has_constant_overrides_the_detection():
    X, y = _data(const=False, seed=15)
    est = adaptid.SlidingWindowRLS(4, 30, P0=P0)
    st = est.run(X, y, stats=True, has_constant=True).stats
    assert st.k_constant == 1
    np.testing.assert_array_equal(st.rsquared[10:], 1 - st.ssr[10:] / st.centered_tss[10:])
    assert not np.allclose(st.rsquared[10:], 1 - st.ssr[10:] / st.uncentered_tss[10:])


def test_off_and_bad_arguments():
    X, y = _data(N=30)
    assert adaptid.RLS(4).run(X, y).stats is None
    assert adaptid.SlidingWindowRLS(4, 10).run(X, y, stats=False).stats is None
    for bad in ("yes", 1, None):
        with pytest.raises(ValueError, match="stats"):
            adaptid.RLS(4).run(X, y, stats=bad)
    with pytest.raises(ValueError, match="has_constant"):
        adaptid.RLS(4).run(X, y, has_constant=True)
    with pytest.raises(ValueError, match="has_constant"):
        adaptid.RLS(4).run(X, y, stats=True, has_constant="no")
    for est in (adaptid.KalmanRLS(4, process_cov=1e-4), adaptid.LMS(4, step=0.01), adaptid.RLS(4, P_max=10.0),
                adaptid.RLS(4, forgetting=adaptid.forgetting.Directional(0.99))):
        with pytest.raises(ValueError, match="stats"):
            est.run(X, y, stats=True)
    with pytest.raises(ValueError, match="stats"):
        adaptid.RLS(4).run_segments(X, y, [0, 30], stats=True)


def test_store_false_still_gives_the_statistics():
    X, y = _data(N=60)
    a = adaptid.SlidingWindowRLS(4, 20, P0=P0).run(X, y, stats=True)
    b = adaptid.SlidingWindowRLS(4, 20, P0=P0).run(X, y, stats=True, store=False)
    assert b.theta.shape[0] == 0
    np.testing.assert_array_equal(a.stats.tvalues, b.stats.tvalues)


# ------------------------------------------------ exact diffuse start (P0="diffuse")
# No prior term: the statistics are those of the window (or of all samples so far)
# alone, so statsmodels' RollingOLS / RollingWLS and the lstsq oracle are matched to
# rounding. Tolerance 1e-10: observed ≤ 1e-14 relative (κ(Φ) < 10, N ≤ 300); the
# ridge of P0 = 1e12 would move them by ~1e-12 (above), a wrong formula by ≥ 1e-2.
RTOL_DIFFUSE = 1e-10


def _close_exact(a, b, nobs, name):
    a, b = np.asarray(a, float), np.asarray(b, float)
    atol = RTOL_DIFFUSE * 10 * np.max(nobs) if name in ("llf", "aic", "bic") else 0.0
    np.testing.assert_allclose(a, b, rtol=RTOL_DIFFUSE, atol=atol, err_msg=name)


def _compare_exact(stats, theta, res, rows):
    nobs = np.asarray(res.nobs)[rows]
    np.testing.assert_array_equal(stats.nobs[rows], nobs)
    _close_exact(theta[rows], np.asarray(res.params)[rows], nobs, "params")
    for f in FIELDS:
        _close_exact(getattr(stats, f)[rows], np.asarray(getattr(res, SM_NAME.get(f, f)))[rows],
                     nobs, f)


def _nan_before_identified(tr, n):
    """Before full rank (the first n − 1 samples here) every fit statistic is NaN,
    as RollingOLS is below its min_nobs = n; at nobs = n there are no degrees of
    freedom: σ̂² and what uses it NaN (statsmodels: ssr/0 = inf), ssr ≈ 0."""
    st = tr.stats
    assert not tr.identified[:n - 1].any() and tr.identified[n - 1]
    for f in FIELDS:
        assert np.isnan(getattr(st, f)[:n - 1]).all(), f
    assert np.isnan(st.sigma2[n - 1]) and np.isnan(st.stderr[n - 1]).all()
    assert abs(st.ssr[n - 1]) < 1e-20 * st.uncentered_tss[n - 1]


@pytest.mark.filterwarnings("ignore:divide by zero:RuntimeWarning",
                            "ignore:invalid value:RuntimeWarning")
@pytest.mark.parametrize("const", [True, False])
def test_diffuse_window_equals_rolling_ols(const):
    X, y = _data(const=const)
    M = 40
    tr = adaptid.SlidingWindowRLS(4, M, P0="diffuse").run(X, y, stats=True)
    res = sm_rolling.RollingOLS(y, X, window=M).fit()
    _compare_exact(tr.stats, tr.theta, res, slice(M - 1, None))
    # (statsmodels divides by nobs − n = 0 at row 3: the warnings filtered above)
    exp = sm_rolling.RollingOLS(y, X, window=M, expanding=True).fit()
    _compare_exact(tr.stats, tr.theta, exp, slice(4, M))  # filling up: nobs 5 … M
    _nan_before_identified(tr, 4)


def test_diffuse_window_equals_rolling_wls():
    X, y = _data(seed=1)
    w = np.random.default_rng(2).uniform(0.2, 3.0, X.shape[0])
    M = 35
    tr = adaptid.SlidingWindowRLS(4, M, P0="diffuse").run(X, y, weights=w, stats=True)
    res = sm_rolling.RollingWLS(y, X, window=M, weights=w).fit()
    _compare_exact(tr.stats, tr.theta, res, slice(M - 1, None))


@pytest.mark.filterwarnings("ignore:divide by zero:RuntimeWarning",
                            "ignore:invalid value:RuntimeWarning")
@pytest.mark.parametrize("lam", [0.97, 1.0])
def test_diffuse_rls_against_weighted_lstsq(lam):
    """All samples so far with weights λ^{k−i} w_i, no prior (the oracle's prior rows
    are zero: p0 = inf); λ = 1 without weights is RollingOLS with an expanding window."""
    X, y = _data(N=250, seed=5)
    w = np.random.default_rng(6).uniform(0.5, 2.0, 250)
    tr = adaptid.RLS(4, forgetting=lam, P0="diffuse").run(X, y, weights=w, stats=True)
    for k in (4, 8, 60, 249):
        c = lam ** np.arange(k, -1, -1.0)
        ref = _direct(X[:k + 1], y[:k + 1], c, w[:k + 1], 4, p0=np.inf)
        assert tr.stats.nobs[k] == k + 1
        _close_exact(tr.stats.n_eff[k], ref["n_eff"], k + 1, "n_eff")
        _close_exact(tr.theta[k], ref["theta"], k + 1, "theta")
        for f in FIELDS:
            _close_exact(getattr(tr.stats, f)[k], ref[f], k + 1, f)
    _nan_before_identified(tr, 4)
    if lam == 1.0:
        tr = adaptid.RLS(4, P0="diffuse").run(X, y, stats=True)
        exp = sm_rolling.RollingOLS(y, X, window=250, expanding=True).fit()
        _compare_exact(tr.stats, tr.theta, exp, slice(4, None))


def test_diffuse_window_losing_rank_is_nan_then_exact_again():
    """Column 3 is zero on samples 60…99, longer than the window: those windows are
    rank-deficient (not identified, NaN statistics; RollingOLS gives a pseudo-inverse
    fit there, not compared); the windows around are exact least squares."""
    X, y = _data(N=160, seed=12)
    X[60:100, 3] = 0.0
    M = 25
    with pytest.warns(adaptid.DefinitenessLossWarning):
        tr = adaptid.SlidingWindowRLS(4, M, P0="diffuse").run(X, y, stats=True)
    lost = np.arange(60 + M - 1, 100)
    assert not tr.identified[lost].any() and tr.identified[100:].all()
    for f in FIELDS:
        assert np.isnan(getattr(tr.stats, f)[lost]).all(), f
    for k in (40, 70, 100, 110, 159):
        a = k + 1 - M
        ref = _direct(X[a:k + 1], y[a:k + 1], np.ones(M), np.ones(M), 4, p0=np.inf)
        _close_exact(tr.theta[k], ref["theta"], M, "theta")
        for f in FIELDS:
            _close_exact(getattr(tr.stats, f)[k], ref[f], M, f)


def test_diffuse_stats_resume_across_runs():
    X, y = _data(N=100, seed=13)
    for make in (lambda: adaptid.RLS(4, forgetting=0.98, P0="diffuse"),
                 lambda: adaptid.SlidingWindowRLS(4, 20, P0="diffuse")):
        one = make().run(X, y, stats=True).stats
        est = make()
        a = est.run(X[:2], y[:2], stats=True).stats  # ends in the diffuse phase
        b = est.run(X[2:], y[2:], stats=True).stats
        for f in FIELDS:
            np.testing.assert_allclose(np.concatenate([getattr(a, f), getattr(b, f)]),
                                       getattr(one, f), rtol=1e-13, atol=0, err_msg=f)


def test_diffuse_batched_equals_one_stream_at_a_time():
    X, y = _data(N=80, seed=14)
    Xb = np.stack([X, X[::-1]])
    yb = np.stack([y, y[::-1]])
    for make in (lambda: adaptid.RLS(4, forgetting=0.99, P0="diffuse"),
                 lambda: adaptid.SlidingWindowRLS(4, 25, P0="diffuse")):
        sb = make().run_batched(Xb, yb, stats=True).stats
        for s in range(2):
            one = make().run(Xb[s], yb[s], stats=True).stats
            for f in FIELDS:
                np.testing.assert_allclose(getattr(sb, f)[s], getattr(one, f), rtol=1e-13,
                                           atol=0, err_msg=f)


def test_diffuse_skipped_samples_in_the_diffuse_phase():
    X, y = _data(N=60, seed=15)
    Xn = X.copy()
    Xn[1, 2] = np.nan
    for make in (lambda: adaptid.RLS(4, P0="diffuse", nan_policy="skip"),
                 lambda: adaptid.SlidingWindowRLS(4, 20, P0="diffuse", nan_policy="skip")):
        st = make().run(Xn, y, stats=True).stats
        ref = make().run(np.delete(X, 1, 0), np.delete(y, 1), stats=True).stats
        assert st.nobs[1] == st.nobs[0] == 1
        for f in FIELDS:  # the row of the skipped sample repeats the one before
            np.testing.assert_allclose(getattr(st, f)[2:], getattr(ref, f)[1:], rtol=1e-12,
                                       atol=0, err_msg=f)

"""adaptid.sklearn.RLSRegressor: scikit-learn's estimator contract, and equality
with the core estimators it adapts and with sklearn's LinearRegression."""

import os
import subprocess
import sys

import numpy as np
import pytest

import sklearn  # noqa: E402,F401  (the test extra installs scikit-learn)

from sklearn.linear_model import LinearRegression
from sklearn.model_selection import KFold, cross_val_score
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.utils.estimator_checks import parametrize_with_checks

import adaptid
from adaptid.sklearn import RLSRegressor


def _expected_failures(est):
    # With forgetting λ < 1 a sample of weight 2 is not the same as the sample
    # twice in a row (the repeat is discounted by λ), by design.
    if est.forgetting != 1.0:
        return {"check_sample_weight_equivalence_on_dense_data":
                "forgetting < 1: a repeated sample is discounted, a weight is not"}
    return {}


@parametrize_with_checks([
    RLSRegressor(),
    RLSRegressor(fit_intercept=False, forgetting=0.999),
    RLSRegressor(method="kalman", process_cov=1e-8, P0=1e6),
    RLSRegressor(window=100),
], expected_failed_checks=_expected_failures)
def test_sklearn_contract(estimator, check):
    check(estimator)


def _data(rng, N=300, nf=3, p=None, noise=0.1):
    X = rng.standard_normal((N, nf))
    coef = rng.standard_normal((nf,) if p is None else (nf, p))
    b = 0.7 if p is None else rng.standard_normal(p)
    y = X @ coef + b + noise * rng.standard_normal((N,) if p is None else (N, p))
    return X, y


def _with_ones(X):
    return np.column_stack([X, np.ones(len(X))])


def _coef_from_theta(theta, nf):
    """sklearn layout from the core's θ = [coef; intercept]."""
    if theta.ndim == 1:
        return theta[:nf], theta[nf]
    return theta[:nf].T, theta[nf]


CORES = [
    (dict(), lambda n, p: adaptid.RLS(n, n_outputs=p)),
    (dict(forgetting=0.97, P0=1e3), lambda n, p: adaptid.RLS(n, forgetting=0.97, P0=1e3, n_outputs=p)),
    (dict(window=40, forgetting=0.99),
     lambda n, p: adaptid.SlidingWindowRLS(n, 40, forgetting=0.99, n_outputs=p)),
    (dict(method="kalman", process_cov=1e-3, noise_var=0.5),
     lambda n, p: adaptid.KalmanRLS(n, process_cov=1e-3, noise_var=0.5, n_outputs=p)),
]


@pytest.mark.parametrize("p", [None, 2])
@pytest.mark.parametrize("params,core", CORES)
def test_fit_equals_core_bit_for_bit(rng, params, core, p):
    X, y = _data(rng, p=p)
    reg = RLSRegressor(**params).fit(X, y)
    ref = core(4, p)
    ref.run(_with_ones(X), y)
    coef, b = _coef_from_theta(ref.theta, 3)
    assert type(reg.estimator_) is type(ref)
    assert np.array_equal(reg.coef_, coef)
    assert np.array_equal(reg.intercept_, b)
    assert np.array_equal(reg.estimator_.P, ref.P)
    assert reg.estimator_.n_updates == ref.n_updates == len(X)
    Xt = rng.standard_normal((7, 3))
    assert np.array_equal(reg.predict(Xt), ref.predict(_with_ones(Xt)))
    assert reg.predict(Xt).shape == ((7,) if p is None else (7, p))


def test_no_intercept_and_sample_weight_equal_core(rng):
    X, y = _data(rng)
    w = rng.uniform(0.1, 2.0, len(X))
    reg = RLSRegressor(fit_intercept=False, forgetting=0.99).fit(X, y, sample_weight=w)
    ref = adaptid.RLS(3, forgetting=0.99)
    ref.run(X, y, weights=w)
    assert np.array_equal(reg.coef_, ref.theta)
    assert reg.intercept_ == 0.0


@pytest.mark.parametrize("p", [None, 2])
@pytest.mark.parametrize("params", [dict(), dict(window=30, forgetting=0.98),
                                    dict(method="kalman", process_cov=1e-4)])
def test_partial_fit_in_chunks_equals_one_fit(rng, params, p):
    X, y = _data(rng, N=257, p=p)
    full = RLSRegressor(**params).fit(X, y)
    part = RLSRegressor(**params)
    for idx in np.array_split(np.arange(len(X)), [1, 50, 51, 130, 200]):
        part.partial_fit(X[idx], y[idx])
    assert np.array_equal(part.coef_, full.coef_)
    assert np.array_equal(part.intercept_, full.intercept_)
    assert np.array_equal(part.estimator_.get_state()["state"], full.estimator_.get_state()["state"])
    assert part.estimator_.n_updates == len(X)


def test_fit_restarts_from_the_prior(rng):
    X, y = _data(rng)
    reg = RLSRegressor(forgetting=0.98)
    reg.partial_fit(X[:100], y[:100])
    reg.fit(X[100:], y[100:])
    ref = RLSRegressor(forgetting=0.98).fit(X[100:], y[100:])
    assert np.array_equal(reg.coef_, ref.coef_)


def test_window_and_forgetting_pass_through(rng):
    X, y = _data(rng)
    reg = RLSRegressor(window=50, forgetting=0.995, P0=123.0).fit(X, y)
    core = reg.estimator_
    assert isinstance(core, adaptid.SlidingWindowRLS)
    assert core.window == 50 and core.forgetting == 0.995
    assert np.array_equal(core.P0, 123.0 * np.eye(4))
    reg = RLSRegressor(forgetting=0.9).fit(X, y)
    assert isinstance(reg.estimator_, adaptid.RLS) and reg.estimator_.forgetting == 0.9
    reg = RLSRegressor(method="kalman", process_cov=2e-3, noise_var=3.0).fit(X, y)
    assert isinstance(reg.estimator_, adaptid.KalmanRLS)
    assert np.array_equal(reg.estimator_.process_cov, 2e-3 * np.eye(4))
    assert reg.estimator_.noise_var == 3.0


def test_forgetting_strategy_passes_through_and_clones(rng):
    from sklearn.base import clone
    from adaptid import forgetting as fg
    X, y = _data(rng)
    strat = fg.Directional(0.97)
    reg = RLSRegressor(forgetting=strat, P0=10.0).fit(X, y)
    assert reg.estimator_.forgetting == strat
    ref = adaptid.RLS(4, forgetting=strat, P0=10.0)
    ref.run(_with_ones(X), y)
    assert np.array_equal(reg.coef_, ref.theta[:3])
    twin = clone(reg)
    assert twin.get_params()["forgetting"] == strat and not hasattr(twin, "coef_")
    assert np.array_equal(twin.fit(X, y).coef_, reg.coef_)


def test_window_tracks_only_the_last_samples(rng):
    # noise-free, the parameters jump; a window of M samples sees only the new ones:
    # compare with an independent batch solve on the last M rows.
    X = rng.standard_normal((200, 2))
    y = np.where(np.arange(200) < 120, X @ [1.0, 2.0] + 1.0, X @ [-3.0, 0.5] - 2.0)
    reg = RLSRegressor(window=50, P0=1e10).fit(X, y)
    ols = LinearRegression().fit(X[-50:], y[-50:])
    np.testing.assert_allclose(reg.coef_, ols.coef_, atol=1e-6)
    np.testing.assert_allclose(reg.intercept_, ols.intercept_, atol=1e-6)


def test_theta0_prior(rng):
    X, y = _data(rng, N=5)
    t0 = np.array([0.3, -0.2, 0.1])
    reg = RLSRegressor(theta0=t0, P0=0.5).fit(X, y)
    ref = adaptid.RLS(4, theta0=np.append(t0, 0.0), P0=0.5)
    ref.run(_with_ones(X), y)
    assert np.array_equal(reg.coef_, ref.theta[:3])
    with pytest.raises(ValueError, match="theta0"):
        RLSRegressor(theta0=np.ones(2)).fit(X, y)


@pytest.mark.parametrize("p", [None, 3])
@pytest.mark.parametrize("fit_intercept", [True, False])
def test_large_prior_equals_linear_regression(rng, p, fit_intercept):
    X, y = _data(rng, N=400, nf=4, p=p)
    reg = RLSRegressor(P0=1e12, fit_intercept=fit_intercept).fit(X, y)
    ols = LinearRegression(fit_intercept=fit_intercept).fit(X, y)
    # the prior (θ−0)ᵀP0⁻¹(θ−0) moves θ by O(|θ|/(P0·λmin(ΦᵀΦ))) ~ 1e-14
    np.testing.assert_allclose(reg.coef_, ols.coef_, rtol=0, atol=1e-6)
    np.testing.assert_allclose(reg.intercept_, ols.intercept_, rtol=0, atol=1e-6)
    np.testing.assert_allclose(reg.predict(X), ols.predict(X), rtol=0, atol=1e-6)
    assert abs(reg.score(X, y) - ols.score(X, y)) < 1e-9


def test_pipeline_and_cross_val_score(rng):
    X, y = _data(rng, N=240, nf=3)
    X = X * [1.0, 100.0, 1e-3] + [5.0, -200.0, 0.0]  # badly scaled columns
    pipe = make_pipeline(StandardScaler(), RLSRegressor(P0=1e10))
    ref = make_pipeline(StandardScaler(), LinearRegression())
    cv = KFold(5, shuffle=True, random_state=0)
    s = cross_val_score(pipe, X, y, cv=cv)
    s_ref = cross_val_score(ref, X, y, cv=cv)
    np.testing.assert_allclose(s, s_ref, rtol=0, atol=1e-8)
    assert s.min() > 0.9
    pipe.fit(X, y)
    np.testing.assert_allclose(pipe.predict(X), ref.fit(X, y).predict(X), atol=1e-6)


def test_dataframe_feature_names(rng):
    import pandas as pd
    X, y = _data(rng, N=50)
    df = pd.DataFrame(X, columns=["u", "v", "w"])
    reg = RLSRegressor().fit(df, y)
    assert list(reg.feature_names_in_) == ["u", "v", "w"]
    assert reg.n_features_in_ == 3
    assert np.array_equal(reg.predict(df), RLSRegressor().fit(X, y).predict(X))
    assert not hasattr(RLSRegressor().fit(X, y), "feature_names_in_")


def test_bad_parameters_raise_at_fit(rng):
    X, y = _data(rng, N=20)
    RLSRegressor(method="bogus", forgetting=7.0)  # __init__ only stores
    with pytest.raises(ValueError, match="method must be one of"):
        RLSRegressor(method="bogus").fit(X, y)
    with pytest.raises(ValueError, match="forgetting"):
        RLSRegressor(forgetting=1.5).fit(X, y)
    with pytest.raises(ValueError, match="window"):
        RLSRegressor(method="window").fit(X, y)
    with pytest.raises(ValueError, match="window"):
        RLSRegressor(window=2).fit(X, y)          # window < n_params = 4
    with pytest.raises(ValueError, match="window"):
        RLSRegressor(window=30, method="rls").fit(X, y)
    with pytest.raises(ValueError, match="forgetting"):
        RLSRegressor(method="kalman", forgetting=0.9).fit(X, y)
    with pytest.raises(ValueError, match="P0"):
        RLSRegressor(P0=-1.0).fit(X, y)
    reg = RLSRegressor().partial_fit(X, y)
    with pytest.raises(ValueError, match="features"):
        reg.partial_fit(X[:, :2], y)
    with pytest.raises(ValueError, match="outputs"):
        reg.partial_fit(X, np.column_stack([y, y]))


def test_missing_sklearn_names_the_extra():
    # a fresh interpreter in which scikit-learn cannot be imported
    code = ("import sys; sys.modules['sklearn'] = None\n"
            "import adaptid\n"
            "try:\n    import adaptid.sklearn\nexcept ImportError as e:\n    print('IE', e)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)})
    assert out.returncode == 0, out.stderr
    assert out.stdout.startswith("IE") and "adaptid[sklearn]" in out.stdout


def test_module_is_reachable_from_the_package():
    import adaptid.sklearn as mod
    assert adaptid.sklearn is mod and mod.RLSRegressor is RLSRegressor


def test_failed_fit_leaves_nothing_and_failed_partial_fit_changes_nothing(rng):
    from sklearn.exceptions import NotFittedError
    X, y = _data(rng, N=30)
    reg = RLSRegressor()
    with pytest.raises(ValueError, match="sample_weight"):
        reg.fit(X, y, sample_weight=-np.ones(30))
    with pytest.raises(NotFittedError):
        reg.predict(X)
    reg.partial_fit(X[:10], y[:10])
    before = reg.estimator_.get_state()["state"].copy(), reg.coef_.copy()
    with pytest.raises(ValueError, match="sample_weight"):
        reg.partial_fit(X[10:], y[10:], sample_weight=np.ones(3))
    assert np.array_equal(reg.estimator_.get_state()["state"], before[0])
    assert np.array_equal(reg.coef_, before[1])
    reg.partial_fit(X[10:], y[10:])
    assert np.array_equal(reg.coef_, RLSRegressor().fit(X, y).coef_)

"""summary() (issue 15, point 2): lstsq's statsmodels-named statistics equal
statsmodels OLS / WLS; the model and recursive summaries against statsmodels,
scipy and the formulas written out in NumPy."""

import numpy as np
import pandas as pd
import pytest
import statsmodels.api as sm
from scipy import stats
from statsmodels.stats.diagnostic import acorr_ljungbox

import adaptid
from adaptid import IDData
from adaptid.models import ARX, OE, arx_regressors, recursive_summary

NAMES = ("tvalues", "pvalues", "rsquared", "rsquared_adj", "llf", "aic", "bic", "df_resid", "ssr")


def _design(rng, N=80, const=True):
    X = rng.standard_normal((N, 3))
    if const:
        X[:, 0] = 1.0
    y = X @ [1.0, -2.0, 0.5] + 0.7 * rng.standard_normal(N)
    return X, y


def _check_all(ours, ref):
    # both solve the same least-squares problem (QR here, pinv/QR there):
    # agreement to ~1e-12 relative; p-values far below 1 compared absolutely
    for name in NAMES:
        np.testing.assert_allclose(np.asarray(getattr(ours, name)), np.asarray(getattr(ref, name)),
                                   rtol=1e-9, atol=1e-13, err_msg=name)
    np.testing.assert_allclose(ours.stderr, ref.bse, rtol=1e-9)
    np.testing.assert_allclose(ours.conf_int(), ref.conf_int(), rtol=1e-9)


@pytest.mark.parametrize("const", [True, False])
def test_lstsq_equals_statsmodels_ols(rng, const):
    X, y = _design(rng, const=const)
    _check_all(adaptid.lstsq(X, y), sm.OLS(y, X).fit())


@pytest.mark.parametrize("const", [True, False])
def test_lstsq_weighted_equals_statsmodels_wls(rng, const):
    X, y = _design(rng, const=const)
    w = rng.uniform(0.2, 3.0, X.shape[0])
    _check_all(adaptid.lstsq(X, y, weights=w), sm.WLS(y, X, weights=w).fit())


def test_lstsq_several_outputs_column_by_column(rng):
    X, y1 = _design(rng)
    y2 = X @ [0.3, 0.1, -1.0] + rng.standard_normal(X.shape[0])
    res = adaptid.lstsq(X, np.column_stack([y1, y2]))
    for j, yj in enumerate((y1, y2)):
        ref = sm.OLS(yj, X).fit()
        for name in ("rsquared", "rsquared_adj", "llf", "aic", "bic", "ssr"):
            assert np.asarray(getattr(res, name))[j] == pytest.approx(getattr(ref, name), rel=1e-9)
        np.testing.assert_allclose(res.tvalues[:, j], ref.tvalues, rtol=1e-9)


def test_lstsq_summary_numbers_and_names(rng):
    X, y = _design(rng)
    df = pd.DataFrame(X, columns=["const", "speed", "load"])
    res = adaptid.lstsq(df, y)
    ref = sm.OLS(y, X).fit()
    s = res.summary()
    assert s.names == ("const", "speed", "load")            # the DataFrame's columns flow in
    ci = ref.conf_int(0.05)
    expected = np.column_stack([ref.params, ref.bse, ref.tvalues, ref.pvalues, ci[:, 0], ci[:, 1]])
    np.testing.assert_allclose(s.params, expected, rtol=1e-9, atol=1e-300)
    for label, value in (("N", 80), ("dof", ref.df_resid), ("R^2", ref.rsquared),
                         ("adj. R^2", ref.rsquared_adj), ("log-likelihood", ref.llf),
                         ("AIC", ref.aic), ("BIC", ref.bic), ("sigma^2", ref.scale),
                         ("SSR", ref.ssr)):
        assert s[label] == pytest.approx(value, rel=1e-9), label
    text = str(s)
    for piece in ("const", "speed", "load", "R^2", "AIC", "P>|t|", "[0.025", "0.975]"):
        assert piece in text
    html = s._repr_html_()
    assert html.startswith("<div>") and "<table>" in html and "speed" in html
    frame = s.to_frame()
    assert list(frame.index) == ["const", "speed", "load"]
    np.testing.assert_allclose(frame["stderr"], ref.bse, rtol=1e-9)
    s90 = res.summary(["a", "b", "c"], alpha=0.1)
    np.testing.assert_allclose(s90.params[:, 4:], ref.conf_int(0.1), rtol=1e-9)
    with pytest.raises(ValueError, match="names must be of length n=3"):
        res.summary(["a"])


@pytest.fixture(scope="module")
def dryer():
    d = adaptid.datasets.load_daisy("dryer")
    return d[:300].detrend(), d[300:].detrend()


def test_arx_summary_equals_statsmodels_and_the_residual_tests(dryer):
    est, _ = dryer
    m = ARX(2, 2, 3).fit(est)
    assert m.dt == 0.08                                    # from the data
    s = m.summary()
    # oracle 1: statsmodels OLS on the same regressors (ARX signs: -y lags)
    reg = arx_regressors(est.y, est.u, 2, 2, 3)
    Phi = reg.Phi * np.array([-1, -1, 1, 1])
    ref = sm.OLS(reg.y, Phi).fit()
    np.testing.assert_allclose(s.params[:, 0], ref.params, rtol=1e-10)
    np.testing.assert_allclose(s.params[:, 1], ref.bse, rtol=1e-9)
    np.testing.assert_allclose(s.params[:, 2], ref.tvalues, rtol=1e-9)
    np.testing.assert_allclose(s.params[:, 4:], ref.conf_int(), rtol=1e-9)
    assert s["N"] == ref.nobs and s["dof"] == ref.df_resid
    assert s["sigma^2"] == pytest.approx(ref.scale, rel=1e-10)
    assert s["log-likelihood"] == pytest.approx(ref.llf, rel=1e-10)
    assert s["AIC"] == pytest.approx(ref.aic, rel=1e-10) == pytest.approx(m.aic, rel=1e-12)
    assert s["BIC"] == pytest.approx(ref.bic, rel=1e-10)
    N, d = int(ref.nobs), 4
    V = ref.ssr / N
    assert s["FPE"] == pytest.approx(V * (1 + d / N) / (1 - d / N), rel=1e-12)   # Ljung eq. 16.31
    # oracle 2: statsmodels' Ljung-Box on the residuals, 25 lags
    lb = acorr_ljungbox(ref.resid, lags=[25], return_df=True)
    assert s["Ljung-Box p (lags 1..25)"] == pytest.approx(float(lb["lb_pvalue"].iloc[0]), rel=1e-8)
    # oracle 3: the residual-input cross-correlation test written out (Ljung 1999, 16.6)
    e = ref.resid - ref.resid.mean()
    uu = est.u[reg.index] - est.u[reg.index].mean()
    r = np.array([np.sum(e[t:] * uu[: N - t]) for t in range(26)]) / np.sqrt((e @ e) * (uu @ uu))
    p_cc = stats.chi2.sf(N * np.sum(r ** 2), 26)
    assert s["cross-corr. p (u, lags 0..25)"] == pytest.approx(p_cc, rel=1e-8)
    # fit %: MATLAB's formula on the one-step prediction (zero initial conditions)
    yhat = m.predict(est)
    fit = 100 * (1 - np.linalg.norm(est.y - yhat) / np.linalg.norm(est.y - est.y.mean()))
    assert s["fit % (1-step, estimation)"] == pytest.approx(fit, rel=1e-12)
    assert "output: y; inputs: u" in str(s) and "ARX(na=2, nb=2, nk=3)" in str(s)


def test_oe_summary_uses_the_model_covariance(dryer):
    est, _ = dryer
    m = OE(2, 2, 3).fit(IDData(est.y, est.u, dt=0.08, y_names="T_out", u_names="heater"))
    s = m.summary(alpha=0.01)
    se = np.sqrt(np.diag(m.cov))
    dof = m.residuals.size - 4
    np.testing.assert_allclose(s.params[:, 1], se, rtol=1e-12)
    np.testing.assert_allclose(s.params[:, 3], 2 * stats.t.sf(np.abs(m.theta / se), dof), rtol=1e-10)
    q = stats.t.ppf(0.995, dof)
    np.testing.assert_allclose(s.params[:, 5], m.theta + q * se, rtol=1e-12)
    assert "cross-corr. p (heater, lags 0..25)" in s.stats
    assert "output: T_out; inputs: heater" in str(s)
    # OE: prediction is simulation
    assert s["fit % (1-step, estimation)"] == pytest.approx(s["fit % (simulation, estimation)"])


def test_recursive_summary_equals_ols_without_forgetting(rng):
    X, y = _design(rng, N=300)
    est = adaptid.RLS(3, P0=1e10)
    est.run(X, y)
    s = recursive_summary(est, pd.DataFrame(X, columns=["c", "x1", "x2"]), y)
    ref = sm.OLS(y, X).fit()
    assert s.names == ("c", "x1", "x2")
    # RLS with a diffuse prior and no forgetting is OLS; the prior P0 = 1e10 I
    # perturbs the solution by ~1e-10 relative
    np.testing.assert_allclose(s.params[:, 0], ref.params, rtol=1e-7)
    np.testing.assert_allclose(s.params[:, 1], ref.bse, rtol=1e-6)
    np.testing.assert_allclose(s.params[:, 3], ref.pvalues, rtol=1e-5, atol=1e-300)
    for label, value in (("log-likelihood", ref.llf), ("AIC", ref.aic), ("BIC", ref.bic),
                         ("dof", ref.df_resid), ("SSR", ref.ssr), ("sigma^2", ref.scale)):
        assert s[label] == pytest.approx(value, rel=1e-6), label


def test_recursive_summary_uses_the_one_sigma_rule(rng):
    X, y = _design(rng, N=300)
    est = adaptid.RLS(3, forgetting=0.98, P0=1e6)
    est.run(X, y)
    s = recursive_summary(est, X, y)
    fs = adaptid.recursive_fit_stats(est, X, y)
    np.testing.assert_array_equal(s.params[:, 1], fs.stderr)
    assert s["sigma^2"] == fs.sigma2 and s["dof"] == fs.dof and s["N effective"] == fs.n_eff
    # p-values from Student's t with the (non-integer) effective dof
    np.testing.assert_allclose(s.params[:, 3], 2 * stats.t.sf(np.abs(est.theta / fs.stderr), fs.dof))
    assert s.names == ("theta0", "theta1", "theta2")


def test_pandas_and_iddata_names_flow_into_the_fit(rng):
    u = rng.standard_normal(400)
    y = np.convolve(u, [0.0, 1.0, 0.5])[:400] + 0.1 * rng.standard_normal(400)
    df = pd.DataFrame({"temp": y, "heat": u})
    m = ARX(1, 2, 1).fit(df["temp"], df["heat"])
    ref = ARX(1, 2, 1).fit(y, u)
    np.testing.assert_array_equal(m.theta, ref.theta)          # the same numbers as from arrays
    assert m.y_name == "temp" and m.u_names == ("heat",)
    s = m.summary()
    assert "cross-corr. p (heat, lags 0..25)" in s.stats and "output: temp; inputs: heat" in str(s)
    G = m.to_control()
    assert list(G.input_labels) == ["heat"] and list(G.output_labels) == ["temp"]
    with pytest.raises(TypeError, match="u must be None when the first argument is an IDData"):
        ARX(1, 2, 1).fit(IDData(y, u), u)
    from adaptid import RLS
    with pytest.raises(TypeError, match="got the estimator RLS: pass it by keyword, estimator="):
        ARX(1, 2, 1).fit_recursive(IDData(y, u), RLS(3))  # by position it lands in u
    with pytest.raises(TypeError, match="u must be an input signal"):
        ARX(1, 2, 1).fit(y)

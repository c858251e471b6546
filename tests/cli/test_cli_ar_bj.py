"""`adaptid fit --ar / --arma / --bj` (issue 16): every --method gives the numbers of the model
objects' fit_recursive (rls, window, kalman) and fit (batch) on the same data, in their
convention (A = 1 + a1 q^-1 + ...), with the --arx naming of input polynomials.

Oracles: statsmodels AutoReg (conditional least squares, the AR batch fit) and the truth of
simulated records (scipy.signal.lfilter); adaptid.models.AR/ARMA/BJ as the Python API the
CLI must agree with.
"""


import numpy as np
import pandas as pd
import pytest
from scipy import signal

import adaptid
from adaptid import models
from ._helpers import run, run_json

METHODS = {
    "rls": ([], {}),
    "window": (["--window", "300"], {"window": 300}),
    "kalman": (["--process-cov", "1e-6"], {"process_cov": 1e-6}),
}




@pytest.fixture(scope="module")
def series(tmp_path_factory):
    """y = C/A e with A = 1 - 1.5 q^-1 + 0.7 q^-2, C = 1 + 0.5 q^-1 (ARMA(2,1))."""
    rng = np.random.default_rng(7)
    e = rng.standard_normal(3000)
    y = signal.lfilter([1, 0.5], [1, -1.5, 0.7], e)
    path = tmp_path_factory.mktemp("ts") / "ts.csv"
    pd.DataFrame({"level": y}).to_csv(path, index=False, float_format="%.17g")
    return path, y


@pytest.fixture(scope="module")
def bj_record(tmp_path_factory):
    """y = B/F u + C/D e, B = q^-2 (1 + 0.5 q^-1), F = 1 - 0.8 q^-1, C = 1 + 0.4 q^-1,
    D = 1 - 0.9 q^-1."""
    rng = np.random.default_rng(11)
    N = 4000
    u = np.sign(rng.standard_normal(N))
    e = 0.1 * rng.standard_normal(N)
    y = signal.lfilter([0, 0, 1.0, 0.5], [1, -0.8], u) + signal.lfilter([1, 0.4], [1, -0.9], e)
    path = tmp_path_factory.mktemp("bj") / "bj.csv"
    pd.DataFrame({"heater": u, "temp": y}).to_csv(path, index=False, float_format="%.17g")
    return path, u, y


# ------------------------------------------------------------------------- AR
def test_ar_batch_equals_models_and_statsmodels_autoreg(series):
    from statsmodels.tsa.ar_model import AutoReg

    path, y = series
    out = run_json("fit", path, "--y", "level", "--ar", "2", "--method", "batch")
    assert out["model"] == "ar" and out["names"] == ["a1", "a2"]
    m = models.AR(2).fit(y)
    np.testing.assert_allclose(out["theta"], m.theta, rtol=1e-12)
    np.testing.assert_allclose(out["stderr"], m.stderr, rtol=1e-10)
    # statsmodels' conditional least squares (trend="n"); its coefficients are -a_j.
    # Both solve the same 2998 x 2 least squares: rounding only
    ref = AutoReg(y, lags=2, trend="n").fit()
    np.testing.assert_allclose(out["theta"], -ref.params, rtol=1e-9)


@pytest.mark.parametrize("method", list(METHODS))
def test_ar_recursive_equals_fit_recursive(series, method):
    path, y = series
    flags, opts = METHODS[method]
    out = run_json("fit", path, "--y", "level", "--ar", "2", "--method", method, *flags)
    m = models.AR(2)
    m.fit_recursive(y, adaptid.estimator(method, 2, **opts))
    # the same compiled recursion over the same regressors (the CLI runs it in chunks, which
    # is bit-for-bit one run): equal to rounding
    np.testing.assert_allclose(out["theta"], m.theta, rtol=1e-10, atol=1e-13)
    if method == "rls":
        # without forgetting, RLS from P0 = 1e4 I is the least-squares solution up to the
        # ridge term 1e-4 I against Φ'Φ ~ 3000·var(y) ~ 1e5: statsmodels AutoReg to 1e-6
        from statsmodels.tsa.ar_model import AutoReg

        np.testing.assert_allclose(out["theta"], -AutoReg(y, lags=2, trend="n").fit().params,
                                   rtol=1e-6)


# ----------------------------------------------------------------------- ARMA
def test_arma_batch_equals_models_arma(series):
    path, y = series
    out = run_json("fit", path, "--y", "level", "--arma", "2,1", "--method", "batch")
    assert out["names"] == ["a1", "a2", "c1"]
    m = models.ARMA(2, 1).fit(y)
    np.testing.assert_allclose(out["theta"], m.theta, rtol=1e-10)
    np.testing.assert_allclose(out["stderr"], m.stderr, rtol=1e-8)
    # the truth of the simulated record, within 4 standard errors
    assert np.all(np.abs(np.asarray(out["theta"]) - [-1.5, 0.7, 0.5]) < 4 * np.asarray(out["stderr"]))


@pytest.mark.parametrize("method", list(METHODS))
def test_arma_recursive_equals_fit_recursive(series, method):
    path, y = series
    flags, opts = METHODS[method]
    out = run_json("fit", path, "--y", "level", "--arma", "2,1", "--method", method, *flags)
    m = models.ARMA(2, 1)
    traj = m.fit_recursive(y, adaptid.estimator(method, 3, **opts))
    np.testing.assert_allclose(out["theta"], m.theta, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(out["stderr"], m.stderr, rtol=1e-10)
    assert out["n_samples"] == len(traj.meta["index"])


def test_arma_tracks_equal_trajectory(series, tmp_path):
    path, y = series
    tracks = tmp_path / "arma.parquet"
    run_json("fit", path, "--y", "level", "--arma", "2,1", "--forgetting", "0.999", "--tracks", tracks)
    df = pd.read_parquet(tracks)
    m = models.ARMA(2, 1)
    traj = m.fit_recursive(y, adaptid.RLS(3, forgetting=0.999))
    np.testing.assert_array_equal(df["sample"], traj.meta["index"])
    np.testing.assert_allclose(df[["a1", "a2", "c1"]].to_numpy(), traj.theta, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(df["error"], traj.error, rtol=1e-12, atol=1e-14)


def test_arma_summary_and_validation(series):
    path, y = series
    out = run_json("fit", path, "--y", "level", "--arma", "2,1", "--method", "batch", "--summary",
                   "--validate", "0.6")
    m = models.ARMA(2, 1).fit(y[:1800])
    ref = m.summary()
    (s,) = out["summary"]
    np.testing.assert_allclose([s["params"][n]["stderr"] for n in ref.names], ref.params[:, 1],
                               rtol=1e-8)
    assert s["stats"]["AIC"] == pytest.approx(ref.stats["AIC"], rel=1e-10)
    # the held-out part: one-step prediction fit (a time series has no simulation)
    v = out["validation"]
    assert v["fit_kind"] == "1-step prediction" and v["cross_correlation_p"] == {}
    yv = y[1800:]
    a1, a2, c1 = m.theta
    # one-step predictor of ARMA written out: e = A/C y, yhat = y - e (zero initial conditions)
    e = signal.lfilter([1, a1, a2], [1, c1], yv)
    fit = 100 * (1 - np.linalg.norm(e) / np.linalg.norm(yv - yv.mean()))
    assert v["fit_percent"] == pytest.approx(fit, rel=1e-9)
    assert v["white"]          # the right structure: white one-step errors on new data


# ------------------------------------------------------------------------- BJ
def test_bj_batch_equals_models_bj(bj_record):
    path, u, y = bj_record
    out = run_json("fit", path, "--y", "temp", "--u", "heater", "--bj", "2,1,1,1,2",
                   "--method", "batch")
    assert out["names"] == ["b0", "b1", "c1", "d1", "f1"]  # BJ's names (issue 33)
    m = models.BJ(2, 1, 1, 1, 2).fit(y, u)
    assert list(m.names) == ["b0", "b1", "c1", "d1", "f1"]
    np.testing.assert_allclose(out["theta"], m.theta, rtol=1e-8)
    # the truth: b = (1, 0.5), c1 = 0.4, d1 = -0.9, f1 = -0.8, within 4 standard errors
    truth = np.array([1.0, 0.5, 0.4, -0.9, -0.8])
    assert np.all(np.abs(np.asarray(out["theta"]) - truth) < 4 * np.asarray(out["stderr"]))


@pytest.mark.parametrize("method", list(METHODS))
def test_bj_recursive_equals_fit_recursive(bj_record, method):
    path, u, y = bj_record
    flags, opts = METHODS[method]
    out = run_json("fit", path, "--y", "temp", "--u", "heater", "--bj", "2,1,1,1,2",
                   "--method", method, *flags)
    m = models.BJ(2, 1, 1, 1, 2)
    m.fit_recursive(y, u, adaptid.estimator(method, 5, **opts))
    np.testing.assert_allclose(out["theta"], m.theta, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(out["stderr"], m.stderr, rtol=1e-10)


def test_bj_validation_simulation(bj_record):
    path, u, y = bj_record
    out = run_json("fit", path, "--y", "temp", "--u", "heater", "--bj", "2,1,1,1,2",
                   "--method", "batch", "--validate", "0.5")
    b0, b1, _, _, f1 = out["theta"]
    ysim = signal.lfilter([0, 0, b0, b1], [1, f1], u[2000:])
    yv = y[2000:]
    fit = 100 * (1 - np.linalg.norm(yv - ysim) / np.linalg.norm(yv - yv.mean()))
    v = out["validation"]
    assert v["fit_kind"] == "simulation"
    assert v["fit_percent"] == pytest.approx(fit, rel=1e-9)
    # the noise model is right: the one-step errors are white and independent of the input
    assert v["white"] and v["independent"] == {"heater": True}


# --------------------------------------------------------------------- errors
@pytest.mark.parametrize("args, needle", [
    (["--y", "temp", "--ar", "0"], "--ar: na must be >= 1"),
    (["--y", "temp", "--ar", "2,1"], "--ar must be na (1 integers)"),
    (["--y", "temp", "--arma", "2"], "--arma must be na,nc (2 integers)"),
    (["--y", "temp", "--arma", "x,1"], "--arma must be na,nc (integers)"),
    (["--y", "temp", "--bj", "2,1,1,1"], "--bj must be nb,nc,nd,nf,nk (5 integers)"),
    (["--y", "temp", "--bj", "2,1,1,1,2"], "--bj needs --u COL"),
    (["--y", "temp", "--u", "heater", "--ar", "2"], "a time-series model has no input"),
    (["--y", "temp", "--arma", "2,1", "--arx", "1,1,1", "--u", "heater"], "cannot be combined"),
    (["--y", "temp", "--arma", "2,1", "--save-state", "s.npz"], "not available with --arma"),
    (["--y", "temp", "--arma", "2,1", "--method", "window"], "--method window needs --window"),
    (["--y", "temp", "--bj", "2,1,1,1,2", "--u", "heater", "--method", "window", "--window", "3"],
     "--window must be at least the number of parameters (5)"),
    (["--y", "temp", "--arma", "2,1", "--intercept"], "--intercept applies to --arx or --fir"),
])
def test_bad_orders_one_line(bj_record, tmp_path, monkeypatch, args, needle):
    path, *_ = bj_record
    monkeypatch.chdir(tmp_path)
    r = run("fit", path, *args)
    assert r.exit_code == 2, r.output
    (line,) = r.stderr.strip().splitlines()
    assert line.startswith("adaptid: error: ") and needle in line, line
    assert not (tmp_path / "s.npz").exists()


def test_time_series_models_in_compare_resid_summary(series):
    """AR/ARMA in compare(k=1), resid and summary() (they call predict(y, u, k=k); before this
    change a TypeError). Oracles: the AR one-step predictor written out, statsmodels' Ljung-Box."""
    from statsmodels.stats.diagnostic import acorr_ljungbox

    _, y = series
    data = adaptid.IDData(y, y_names="level")
    est, val = data.split(0.5)
    m = models.AR(2).fit(est.y)
    a1, a2 = m.theta
    yv = val.y
    yhat = np.zeros(len(yv))              # zero before the first sample
    yhat[1] = -a1 * yv[0]
    yhat[2:] = -a1 * yv[1:-1] - a2 * yv[:-2]
    fit = 100 * (1 - np.linalg.norm(yv - yhat) / np.linalg.norm(yv - yv.mean()))
    assert models.compare(val, m, k=1).fit[0] == pytest.approx(fit, rel=1e-10)
    r = models.resid(val, m)
    lb = acorr_ljungbox((yv - yhat)[2:], lags=[25], return_df=True)["lb_pvalue"].iloc[0]
    assert r.autocorrelation["p_value"] == pytest.approx(lb, rel=1e-8)
    assert r.cross_correlation == [] and r.u_names == ()
    s = m.summary()
    assert "inputs: none" in s.notes[0] and "fit % (simulation, estimation)" not in s.stats
    with pytest.raises(TypeError, match="u must be None"):
        m.predict(yv, np.ones(len(yv)), k=1)

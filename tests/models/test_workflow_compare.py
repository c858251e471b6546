"""compare, resid, select_order (issue 15, points 3-4) and the figures, against
MATLAB's fit formula written out in NumPy, statsmodels' acf / acorr_ljungbox,
and a brute-force order search by separate least-squares solves."""

import itertools

import matplotlib
import numpy as np
import pandas as pd
import pytest
from scipy import stats
from scipy.signal import lfilter
from statsmodels.stats.diagnostic import acorr_ljungbox
from statsmodels.tsa.stattools import acf

import adaptid
from adaptid import IDData
from adaptid.models import ARX, OE, arx_regressors, compare, resid, select_order

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def _png(fig, path):
    fig.savefig(path)
    plt.close(fig)
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 5000
    return path


@pytest.fixture(scope="module")
def plant():
    rng = np.random.default_rng(15)
    N = 1500
    u = np.sign(rng.standard_normal(N))
    # y = B/A u + 1/A e with A = 1 - 1.2 q^-1 + 0.5 q^-2, B = q^-2 (1 + 0.5 q^-1): ARX(2, 2, 2)
    A, B = [1.0, -1.2, 0.5], [0.0, 0.0, 1.0, 0.5]
    y = lfilter(B, A, u) + lfilter([1.0], A, 0.1 * rng.standard_normal(N))
    data = IDData(y, u, dt=0.01, y_names="speed", u_names="voltage")
    return data.split(0.6)


def _matlab_fit(y, yhat):
    # MATLAB compare's NRMSE fit, written out
    return 100.0 * (1.0 - np.sqrt(np.sum((y - yhat) ** 2)) / np.sqrt(np.sum((y - np.mean(y)) ** 2)))


def test_compare_simulation_and_prediction(plant, tmp_path):
    est, val = plant
    arx = ARX(2, 2, 2).fit(est)
    oe = OE(2, 2, 2).fit(est)
    res = compare(val, arx, oe)
    # simulation from the polynomials, independently of the model's code
    A = np.r_[1.0, arx.theta[:2]]
    B = np.r_[0.0, 0.0, arx.theta[2:]]
    y_sim = lfilter(B, A, val.u)
    assert res.fit[0] == pytest.approx(_matlab_fit(val.y, y_sim), rel=1e-12)
    y_oe = lfilter(np.r_[0.0, 0.0, oe.theta[:2]], np.r_[1.0, oe.theta[2:]], val.u)
    assert res.fit[1] == pytest.approx(_matlab_fit(val.y, y_oe), rel=1e-12)
    assert res.fit.min() > 80
    # one-step prediction of ARX: y_hat_k = phi_k^T theta with zero initial conditions
    p1 = compare(val, arx, k=1)
    ypad, upad = np.r_[0.0, 0.0, val.y], np.r_[0.0, 0.0, 0.0, val.u]
    n = len(val)
    yhat = (-arx.theta[0] * ypad[1:n + 1] - arx.theta[1] * ypad[:n]
            + arx.theta[2] * upad[1:n + 1] + arx.theta[3] * upad[:n])
    assert p1.fit[0] == pytest.approx(_matlab_fit(val.y, yhat), rel=1e-10)
    assert p1.fit[0] > res.fit[0]          # one-step prediction beats simulation here
    assert "1-step prediction" in repr(p1)
    # the figure, drawn into a given axes: labelled with the data's names
    fig, ax = plt.subplots()
    res2 = compare(val, arx, oe, ax=ax, names=["ARX", "OE"])
    assert res2.figure is fig and ax.get_ylabel() == "speed"
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert legend[0] == "speed (measured)" and legend[1].startswith("ARX: ")
    _png(fig, tmp_path / "compare.png")


def test_compare_accepts_tuples_and_frames(plant):
    est, val = plant
    m = ARX(2, 2, 2).fit(est.y, est.u)
    a = compare(val, m).fit
    b = compare((val.y, val.u), m).fit
    c = compare(pd.DataFrame({"y": val.y, "u": val.u}), m).fit
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(a, c)
    with pytest.raises(TypeError, match="models must be at least one fitted model"):
        compare(val)
    with pytest.raises(TypeError, match="data must be an IDData"):
        compare(np.ones(3), m)


def test_resid_against_statsmodels_and_numpy(plant, tmp_path):
    est, val = plant
    arx = ARX(2, 2, 2).fit(est)
    r = resid(val, arx, max_lag=20, alpha=0.01)
    # the first max(na, nk + nb - 1) = 3 predictions need samples before the record
    assert r.start == 3
    e = (val.y - arx.predict(val))[3:]
    np.testing.assert_allclose(r.e, e)
    N = e.size
    # autocorrelation and Ljung-Box: statsmodels
    np.testing.assert_allclose(r.autocorrelation["acf"], acf(e, nlags=20, adjusted=False), atol=1e-12)
    lb = acorr_ljungbox(e, lags=[20], return_df=True)
    assert r.autocorrelation["q_stat"] == pytest.approx(float(lb["lb_stat"].iloc[0]), rel=1e-10)
    assert r.autocorrelation["p_value"] == pytest.approx(float(lb["lb_pvalue"].iloc[0]), rel=1e-8)
    assert r.autocorrelation["band"] == pytest.approx(stats.norm.ppf(0.995) / np.sqrt(N))
    # cross-correlation, written out for every lag -20..20
    uv = val.u[3:]
    ec, uc = e - e.mean(), uv - uv.mean()
    den = np.sqrt((ec @ ec) * (uc @ uc))
    ccf = [np.sum(ec[t:] * uc[:N - t]) / den if t >= 0 else np.sum(ec[:N + t] * uc[-t:]) / den
           for t in range(-20, 21)]
    cc = r.cross_correlation[0]
    np.testing.assert_allclose(cc["ccf"], ccf, atol=1e-12)
    assert cc["p_value"] == pytest.approx(stats.chi2.sf(N * np.sum(np.square(ccf[20:])), 21), rel=1e-10)
    # the true structure: white residuals, independent of the input
    assert r.white and r.independent == (True,)
    # a model one order too small is caught by both tests
    bad = resid(val, ARX(1, 1, 2).fit(est))
    assert not bad.white and bad.independent == (False,)
    assert "white=False" in repr(bad)
    # the figure: one panel for the autocorrelation, one per input
    fig, axes = plt.subplots(2, 1)
    r2 = resid(val, arx, ax=axes)
    assert r2.figure is fig
    assert "speed" in axes[0].get_ylabel() and "voltage" in axes[1].get_ylabel()
    assert axes[1].get_xlabel() == "lag (samples)"
    _png(fig, tmp_path / "resid.png")
    _png(bad.plot(), tmp_path / "resid_bad.png")


def test_select_order_equals_brute_force(plant):
    est, val = plant
    grid = dict(na=[1, 2, 3], nb=[1, 2, 3], nk=[1, 2, 3])
    sel = select_order(est, **grid)
    assert isinstance(sel.table, pd.DataFrame) and len(sel.table) == 27
    y, u = est.y, est.u
    s = max(3, 3 + 3 - 1)                  # the common first row of the shared matrix
    rows = []
    for na, nb, nk in itertools.product(*grid.values()):
        # brute force: the structure's own regressors, cut to the common rows, separate solve
        reg = arx_regressors(y, u, na, nb, nk)
        keep = reg.index >= s
        Phi = reg.Phi[keep] * np.r_[-np.ones(na), np.ones(nb)]
        theta, *_ = np.linalg.lstsq(Phi, reg.y[keep], rcond=None)
        r = reg.y[keep] - Phi @ theta
        N, d = r.size, na + nb
        V = r @ r / N
        rows.append((na, nb, nk, V, N * np.log(V) + 2 * d + N * (np.log(2 * np.pi) + 1),
                     V * (1 + d / N) / (1 - d / N)))
    ref = np.array(rows)
    got = sel.table[["na", "nb", "nk", "loss", "aic", "fpe"]].to_numpy()
    np.testing.assert_allclose(got, ref, rtol=1e-9)
    assert sel.best == tuple(int(v) for v in ref[np.argmin(ref[:, 4]), :3]) == (2, 2, 2)
    assert select_order(est, **grid, criterion="fpe").best == (2, 2, 2)
    assert np.isnan(sel.table["fit_validation"]).all()


def test_select_order_by_validation(plant):
    est, val = plant
    sel = select_order(est, na=[1, 2], nb=[1, 2], nk=2, criterion="validation", validation=val)
    tab = sel.table
    # the validation fit of (2, 2, 2), from a separate ARX fit on the same common rows
    reg = arx_regressors(est.y, est.u, 2, 2, 2)
    keep = reg.index >= 3
    theta, *_ = np.linalg.lstsq(reg.Phi[keep] * [-1, -1, 1, 1], reg.y[keep], rcond=None)
    y_sim = lfilter(np.r_[0, 0, theta[2:]], np.r_[1, theta[:2]], val.u)
    row = tab[(tab.na == 2) & (tab.nb == 2)].iloc[0]
    assert row["fit_validation"] == pytest.approx(_matlab_fit(val.y, y_sim), rel=1e-9)
    assert sel.best == (2, 2, 2) and "best" in sel._repr_html_()
    with pytest.raises(ValueError, match="validation must be a record when criterion='validation'"):
        select_order(est, na=1, nb=1, nk=1, criterion="validation")
    with pytest.raises(ValueError, match="criterion must be one of"):
        select_order(est, na=1, nb=1, criterion="bic")
    with pytest.raises(ValueError, match="nb must be"):
        select_order(est, na=1, nb=0)


def test_trajectory_carries_names_and_time(plant, tmp_path):
    est, _ = plant
    m = ARX(2, 2, 2)
    traj = m.fit_recursive(est, estimator=adaptid.RLS(4, P0=1e6))
    assert traj.names == m.names == ("a1", "a2", "b0", "b1")
    np.testing.assert_allclose(traj.time, est.t[traj.meta["index"]])
    df = traj.to_pandas()
    assert list(df.columns[:4]) == list(m.names) and df.index.name == "time"
    np.testing.assert_allclose(df.index.to_numpy(), est.t[3:])   # rows from max(na, nk+nb-1) = 3
    # from arrays: no time stamps, the sample positions index the frame
    t2 = ARX(2, 2, 2).fit_recursive(est.y, est.u)
    assert t2.time is None and t2.to_pandas().index.name == "k"
    # tracks figure, one labelled panel per parameter
    fig = traj.plot()
    assert [ax.get_ylabel() for ax in fig.axes] == ["a1", "a2", "b0", "b1"]
    _png(fig, tmp_path / "tracks.png")
    # with a standard-error history: ±2σ bands (a filled area per panel)
    import dataclasses
    se = np.full(traj.theta.shape, 0.01)
    fig = dataclasses.replace(traj, stderr=se).plot()
    assert all(len(ax.collections) >= 1 for ax in fig.axes)
    _png(fig, tmp_path / "tracks_band.png")


def test_oe_pseudolinear_trajectory_has_names(plant):
    est, _ = plant
    m = OE(2, 2, 2)
    traj = m.fit_recursive(est)
    assert traj.names == ("b0", "b1", "f1", "f2") and traj.time is not None


def test_estimator_run_takes_names_and_time_from_pandas():
    """Issue 15, point 6: a trajectory knows the names and time index of the
    data it came from without being told (here: a DataFrame Phi)."""
    import adaptid

    rng = np.random.default_rng(5)
    t = pd.date_range("2026-01-01", periods=300, freq="s")
    X = pd.DataFrame(rng.standard_normal((300, 2)), columns=["R", "Ke"], index=t)
    y = pd.Series(X.to_numpy() @ [1.0, 2.0], index=t)
    tr = adaptid.RLS(2, P0=1e8).run(X, y)
    df = tr.to_pandas()
    assert list(df.columns[:2]) == ["R", "Ke"]
    assert (df.index == t).all()
    np.testing.assert_allclose(df[["R", "Ke"]].to_numpy()[-1], [1.0, 2.0], rtol=1e-7)
    plain = adaptid.RLS(2, P0=1e8).run(X.to_numpy(), y.to_numpy())
    assert plain.names is None and plain.time is None
    np.testing.assert_array_equal(plain.theta, tr.theta)

"""Several experiments and gaps (issue 34, point 1): IDData.merge, the rows of
every regressor builder and model formed inside each experiment, NaN gaps.

The oracles are NumPy: each experiment's rows written out by hand with
array indexing, stacked, and solved by numpy.linalg.lstsq."""

import numpy as np
import pandas as pd
import pytest
from scipy.signal import lfilter

from adaptid import IDData


def _plant(rng, N, a=(1.0, -1.5, 0.7), b=(0.0, 1.0, 0.5), noise=0.1):
    u = rng.standard_normal(N)
    y = lfilter(b, a, u) + noise * rng.standard_normal(N)
    return y, u


@pytest.fixture
def three(rng):
    recs = []
    for N, dt in ((300, 0.1), (200, 0.1), (250, 0.1)):
        y, u = _plant(rng, N)
        recs.append(IDData(y, u, dt, y_names="out", u_names="in"))
    return recs


# ------------------------------------------------------------------ IDData
def test_merge_keeps_experiments(three):
    a, b, c = three
    m = a.merge(b, c)
    assert m.n_experiments == 3 and len(m) == 750
    assert [len(e) for e in m.experiments] == [300, 200, 250]
    np.testing.assert_array_equal(m.bounds, [0, 300, 500, 750])
    np.testing.assert_array_equal(m.experiment(1).y, b.y)
    np.testing.assert_array_equal(m.outputs[:, 0], np.r_[a.y, b.y, c.y])
    # each experiment keeps its own time axis
    np.testing.assert_allclose(m.t, np.r_[a.t, b.t, c.t])
    assert m.y_names == ("out",) and m.u_names == ("in",) and m.dt == 0.1
    assert "experiments=3" in repr(m)
    # merging merged records flattens them; a single record is one experiment
    assert m.merge(a).n_experiments == 4 and a.n_experiments == 1 and a.experiments == [a]
    with pytest.raises(ValueError, match="k must be"):
        m.experiment(3)


def test_merge_refuses_other_signals_and_dt(three):
    a = three[0]
    with pytest.raises(ValueError, match=r"others\[0\].*dt=0.1"):
        a.merge(IDData(np.ones(10), np.ones(10), 0.2, y_names="out", u_names="in"))
    with pytest.raises(ValueError, match=r"others\[1\].*outputs \['out'\]"):
        a.merge(three[1], IDData(np.ones(10), np.ones(10), 0.1))
    with pytest.raises(TypeError, match=r"others\[0\]"):
        a.merge(np.ones(10))
    with pytest.raises(TypeError, match="merged record"):
        a.merge(three[1])[10:20]


def test_merge_frame_split_detrend(three):
    m = three[0].merge(three[1])
    df = m.to_frame()
    assert df.index.names == ["experiment", "time"]
    pd.testing.assert_frame_equal(df.loc[1], three[1].to_frame())
    est, val = m.split(0.6)
    assert est.n_experiments == val.n_experiments == 2
    assert [len(e) for e in est.experiments] == [180, 120]
    np.testing.assert_array_equal(val.experiment(1).y, three[1].y[120:])
    dd = m.detrend("linear")
    for e in range(2):    # oracle: each experiment's own detrend
        np.testing.assert_allclose(dd.experiment(e).y, three[e].detrend("linear").y, atol=1e-12)
    np.testing.assert_allclose(dd.retrend(dd.y), m.y, atol=1e-12)
    import matplotlib

    matplotlib.use("Agg")
    fig = m.plot()
    assert len(fig.axes[0].lines) == 2       # one line per experiment, on its own time axis
    np.testing.assert_allclose(fig.axes[0].lines[1].get_xdata(), three[1].t)


def test_nan_samples_are_kept_and_detrended_around(rng):
    y = rng.standard_normal(50) + 3.0
    y[[5, 6, 30]] = np.nan
    d = IDData(y, rng.standard_normal(50))
    assert "3 sample(s) with NaN" in repr(d)
    dd = d.detrend()
    ok = ~np.isnan(y)
    np.testing.assert_allclose(dd.y[ok], y[ok] - y[ok].mean(), atol=1e-12)
    assert np.isnan(dd.y[[5, 6, 30]]).all()
    with pytest.raises(ValueError, match="y must be"):
        IDData(np.r_[1.0, np.inf], np.ones(2))


# ------------------------------------------------------ regressors and ARX
def _rows_by_hand(y, u, na, nb, nk):
    """ARX rows [y[k-1..k-na], u[k-nk..k-nk-nb+1]] of one experiment, k = s … N-1."""
    s = max(na, nk + nb - 1)
    Phi = [[y[k - j] for j in range(1, na + 1)] + [u[k - nk - j] for j in range(nb)]
           for k in range(s, len(y))]
    return np.array(Phi, dtype=float).reshape(-1, na + nb), y[s:]


def test_arx_regressors_of_merged_records_stack_each_experiments_rows(three):
    from adaptid.models import arx_regressors, fir_regressors

    m = three[0].merge(*three[1:])
    reg = arx_regressors(m, None, 2, 3, 2)
    blocks = [_rows_by_hand(e.y, e.u, 2, 3, 2) for e in three]
    np.testing.assert_array_equal(reg.Phi, np.vstack([b[0] for b in blocks]))
    np.testing.assert_array_equal(reg.y, np.concatenate([b[1] for b in blocks]))
    # index: the rows' positions in the concatenated signals; s = nk + nb - 1 = 4 lags
    np.testing.assert_array_equal(reg.index, np.r_[4:300, 304:500, 504:750])
    np.testing.assert_array_equal(reg.meta["row_bounds"], [0, 296, 492, 738])
    # lists of records give the same rows
    reg2 = arx_regressors([e.y for e in three], [e.u for e in three], 2, 3, 2)
    np.testing.assert_array_equal(reg2.Phi, reg.Phi)
    fir = fir_regressors(m, None, 3, 1)
    np.testing.assert_array_equal(
        fir.Phi, np.vstack([_rows_by_hand(e.y, e.u, 0, 3, 1)[0] for e in three]))


def test_arx_fit_of_merged_records_is_lstsq_on_stacked_rows(three):
    from adaptid.models import AR, ARX

    m = three[0].merge(*three[1:])
    blocks = [_rows_by_hand(e.y, e.u, 2, 2, 1) for e in three]
    Phi = np.vstack([b[0] for b in blocks])
    Phi[:, :2] *= -1                      # MATLAB's sign of the a coefficients
    target = np.concatenate([b[1] for b in blocks])
    theta = np.linalg.lstsq(Phi, target, rcond=None)[0]
    model = ARX(2, 2, 1).fit(m)
    np.testing.assert_allclose(model.theta, theta, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(model.residuals, target - Phi @ theta, atol=1e-10)
    assert model.n_experiments == 3 and model.n_dropped == 0
    st = model.summary().stats
    assert st["experiments"] == 3 and "rows left out (NaN)" not in st
    # its fit % is the one-step prediction of each experiment from rest (oracle: lfilter)
    y1 = np.concatenate([lfilter(-np.r_[0.0, model.A[1:]], [1.0], e.y)
                         + lfilter(model.B, [1.0], e.u) for e in three])
    fit = 100 * (1 - np.linalg.norm(m.y - y1) / np.linalg.norm(m.y - m.y.mean()))
    np.testing.assert_allclose(st["fit % (1-step, estimation)"], fit, rtol=1e-10)
    # the concatenated record would have 2 more rows (lags across the two boundaries)
    assert ARX(2, 2, 1).fit(m.y, m.u).residuals.size == model.residuals.size + 4
    # the recursive fit runs over the same stacked rows
    traj = ARX(2, 2, 1).fit_recursive(m)
    assert traj.theta.shape[0] == target.size
    # AR: each experiment's rows
    ar = AR(2).fit(IDData(three[0].y).merge(IDData(three[1].y)))
    rows = [_rows_by_hand(e.y, e.u, 2, 0, 1) for e in three[:2]]
    Phi = -np.vstack([r[0] for r in rows])
    np.testing.assert_allclose(ar.theta, np.linalg.lstsq(Phi, np.concatenate([r[1] for r in rows]),
                                                         rcond=None)[0], rtol=1e-10)


def test_arx_leaves_out_the_rows_that_touch_a_nan(rng):
    from adaptid.models import ARX

    y, u = _plant(rng, 400)
    y[[50, 51, 200]] = np.nan
    u[300] = np.nan
    Phi, target = _rows_by_hand(y, u, 2, 2, 1)
    keep = np.isfinite(Phi).all(axis=1) & np.isfinite(target)
    Phi[:, :2] *= -1
    theta = np.linalg.lstsq(Phi[keep], target[keep], rcond=None)[0]
    model = ARX(2, 2, 1).fit(y, u)
    np.testing.assert_allclose(model.theta, theta, rtol=1e-10)
    # y[50], y[51]: rows 50-53; y[200]: rows 200-202; u[300]: rows 301-302
    assert model.n_dropped == int((~keep).sum()) == 9
    assert "rows left out (NaN)" in model.summary().stats
    assert model.summary().stats["rows left out (NaN)"] == 9
    with pytest.raises(ValueError, match="y must be without NaN"):
        ARX(2, 2, 1).fit(y, u, nan_policy="raise")
    with pytest.raises(ValueError, match="nan_policy must be"):
        ARX(2, 2, 1).fit(y, u, nan_policy="skip")


# ------------------------------------------------------- filter-based models
def _armax_errors(theta, recs, na, nb, nc, nk):
    """Oracle: per experiment, ε = (A y − B u)/C on the rows k ≥ s, filters from zero."""
    a, b, c = theta[:na], theta[na: na + nb], theta[na + nb:]
    s = max(na, nk + nb - 1)
    out = []
    for y, u in recs:
        v = lfilter(np.r_[1.0, a], [1.0], y) - lfilter(np.r_[np.zeros(nk), b], [1.0], u)
        out.append(lfilter([1.0], np.r_[1.0, c], v[s:]))
    return np.concatenate(out)


def _oe_errors(theta, recs, nb, nf, nk):
    """Oracle: per experiment, ε = y − B/F u on the rows k ≥ s, F's filter from zero at s."""
    b, f = theta[:nb], theta[nb:]
    s = nk + nb - 1
    out = []
    for y, u in recs:
        bu = lfilter(np.r_[np.zeros(nk), b], [1.0], u)[s:]
        out.append(y[s:] - lfilter([1.0], np.r_[1.0, f], bu))
    return np.concatenate(out)


def _two_armax_records(rng):
    recs = []
    for N in (700, 500):
        u = rng.standard_normal(N)
        e = 0.2 * rng.standard_normal(N)
        y = lfilter([0, 1.0, 0.5], [1, -1.2, 0.5], u) + lfilter([1, 0.6], [1, -1.2, 0.5], e)
        recs.append((y, u))
    return recs


def test_armax_criterion_sums_over_experiments(rng):
    """The PEM estimate on a merged record minimises the sum over the experiments of the
    oracle's per-experiment prediction errors (scipy's least_squares on the oracle)."""
    from scipy.optimize import least_squares
    from adaptid.models import ARMAX

    recs = _two_armax_records(rng)
    m = IDData(*recs[0]).merge(IDData(*recs[1]))
    model = ARMAX(2, 2, 1, 1).fit(m)
    np.testing.assert_allclose(model.residuals, _armax_errors(model.theta, recs, 2, 2, 1, 1),
                               atol=1e-10)
    ref = least_squares(_armax_errors, np.r_[-1.0, 0.4, 0.8, 0.3, 0.3], args=(recs, 2, 2, 1, 1),
                        xtol=1e-12, ftol=1e-12, gtol=1e-12)
    # both minimise the same smooth criterion from different starts: 1e-5 leaves room for
    # the two optimisers' stopping rules
    np.testing.assert_allclose(model.theta, ref.x, atol=1e-5)
    assert model.n_experiments == 2
    # concatenating the records instead (filters running across the boundary) differs
    cat = ARMAX(2, 2, 1, 1).fit(m.y, m.u)
    assert cat.residuals.size == model.residuals.size + 2


def test_oe_criterion_sums_over_experiments_and_gaps_split_the_record(rng):
    from scipy.optimize import least_squares
    from adaptid.models import OE

    recs = []
    for N in (600, 400):
        u = rng.standard_normal(N)
        recs.append((lfilter([0, 1.0, 0.5], [1, -0.7], u) + 0.1 * rng.standard_normal(N), u))
    m = IDData(*recs[0]).merge(IDData(*recs[1]))
    model = OE(2, 1, 1).fit(m)
    np.testing.assert_allclose(model.residuals, _oe_errors(model.theta, recs, 2, 1, 1), atol=1e-10)
    ref = least_squares(_oe_errors, np.r_[0.5, 0.2, -0.3], args=(recs, 2, 1, 1),
                        xtol=1e-12, ftol=1e-12, gtol=1e-12)
    np.testing.assert_allclose(model.theta, ref.x, atol=1e-6)
    # one record with a NaN gap where the second starts = the two runs merged
    y = np.r_[recs[0][0], np.nan, np.nan, recs[1][0]]
    u = np.r_[recs[0][1], 0.0, 0.0, recs[1][1]]
    gap = OE(2, 1, 1).fit(y, u)
    np.testing.assert_allclose(gap.theta, model.theta, rtol=1e-9)
    np.testing.assert_allclose(gap.residuals, model.residuals, rtol=1e-9, atol=1e-12)
    # the rows left out: 2 samples of gap + 2 lag rows to restart after it
    assert gap.n_dropped == 2 + 2
    with pytest.raises(ValueError, match="y must be without NaN"):
        OE(2, 1, 1).fit(y, u, nan_policy="raise")
    # the recursion takes the gap too (issue 34): as on the merged record
    np.testing.assert_array_equal(OE(2, 1, 1).fit_recursive(y, u).theta,
                                  OE(2, 1, 1).fit_recursive(m).theta)


def test_bj_and_arma_run_per_experiment(rng):
    from adaptid.models import ARMA, BJ

    recs = _two_armax_records(rng)
    m = IDData(*recs[0]).merge(IDData(*recs[1]))
    bj = BJ(2, 1, 1, 2, 1).fit(m)
    assert bj.residuals.size == (700 - 2) + (500 - 2) and bj.n_experiments == 2
    e = rng.standard_normal(1500)
    y = lfilter([1, 0.5], [1, -0.8], e)
    two = IDData(y[:900]).merge(IDData(y[900:]))
    arma = ARMA(1, 1).fit(two)
    assert arma.residuals.size == 899 + 599
    np.testing.assert_allclose(arma.theta, [-0.8, 0.5], atol=0.08)
    # a gap in a time series: the rows on each side, restarted
    yg = y.copy()
    yg[700:705] = np.nan
    g = ARMA(1, 1).fit(yg)
    assert g.residuals.size == 699 + 794 and g.n_dropped == 6


# --------------------------------------------- state space and NARX: as lists
def _ss_records(rng, lengths=(800, 600)):
    from adaptid.models import StateSpaceModel

    true = StateSpaceModel([[0.9, 0.2], [0.0, 0.5]], [[1.0], [1.0]], [[1.0, 0.0]])
    recs = []
    for N in lengths:
        u = rng.standard_normal((N, 1))
        recs.append((true.simulate(u) + 0.01 * rng.standard_normal((N, 1)), u))
    return recs


def test_n4sid_and_okid_take_a_merged_record_as_its_experiments(rng):
    from adaptid.models import n4sid, okid

    recs = _ss_records(rng)
    m = IDData(*recs[0]).merge(IDData(*recs[1]))
    a = n4sid(m, 2, horizon=8)
    b = n4sid([IDData(*r) for r in recs], 2, horizon=8)
    assert a.info["experiments"] == 2
    np.testing.assert_allclose(a.singular_values, b.singular_values, rtol=1e-12)
    np.testing.assert_allclose(np.sort(a.poles().real), np.sort(b.poles().real), rtol=1e-10)
    c = okid(m, 2, 10)
    d = okid([IDData(*r) for r in recs], 2, 10)
    np.testing.assert_allclose(np.sort(c.poles().real), np.sort(d.poles().real), rtol=1e-10)


def test_n4sid_splits_a_record_at_nan_gaps(rng):
    from adaptid.models import n4sid

    recs = _ss_records(rng)
    y = np.vstack([recs[0][0], np.full((3, 1), np.nan), recs[1][0]])
    u = np.vstack([recs[0][1], np.zeros((3, 1)), recs[1][1]])
    gap = n4sid((y, u), 2, horizon=8)
    runs = n4sid(list(recs), 2, horizon=8)
    assert gap.info["experiments"] == 2
    np.testing.assert_allclose(gap.singular_values, runs.singular_values, rtol=1e-12)
    # a run shorter than 2·horizon between two gaps is left out
    y2 = np.vstack([recs[0][0], [[np.nan]], recs[1][0][:5], [[np.nan]], recs[1][0]])
    u2 = np.vstack([recs[0][1], [[0.0]], recs[1][1][:5], [[0.0]], recs[1][1]])
    short = n4sid((y2, u2), 2, horizon=8)
    np.testing.assert_allclose(short.singular_values, runs.singular_values, rtol=1e-12)


def test_narx_takes_a_merged_record_and_splits_at_gaps(rng):
    from adaptid.models import NARX

    recs = []
    for N in (400, 300):
        u = rng.uniform(-1, 1, N)
        y = np.zeros(N)
        for k in range(1, N):
            y[k] = 0.5 * y[k - 1] + u[k - 1] + 0.2 * u[k - 1] ** 2
        recs.append(IDData(y, u))
    a = NARX(1, 1, 2, n_terms=3).fit(recs[0].merge(recs[1]))
    b = NARX(1, 1, 2, n_terms=3).fit(recs)
    np.testing.assert_allclose(a.theta, b.theta, rtol=1e-10)
    y = np.r_[recs[0].y, np.nan, recs[1].y]
    u = np.r_[recs[0].u, 0.0, recs[1].u]
    c = NARX(1, 1, 2, n_terms=3).fit(y, u)
    np.testing.assert_allclose(c.theta, b.theta, rtol=1e-10)


# ----------------------------------------------------------- compare, resid
def test_compare_runs_each_experiment_from_rest(three):
    from adaptid.models import ARX, compare

    m = three[0].merge(*three[1:])
    model = ARX(2, 2, 1).fit(three[0])
    res = compare(m, model)
    # oracle: lfilter of each experiment's input alone, from zero initial conditions
    A, B = model.A, model.B
    sims = [lfilter(B, A, e.u) for e in three]
    np.testing.assert_allclose(res.y_hat[0], np.concatenate(sims), atol=1e-12)
    y = m.y
    fit = 100 * (1 - np.linalg.norm(y - res.y_hat[0]) / np.linalg.norm(y - y.mean()))
    np.testing.assert_allclose(res.fit[0], fit, rtol=1e-12)
    for k, e in enumerate(three):
        np.testing.assert_allclose(res.fit_experiments[0, k], compare(e, model).fit[0], rtol=1e-12)
    # a NaN gap: the simulation restarts after it, the gap is NaN and left out of the fit
    yg, ug = m.experiment(0).y.copy(), m.experiment(0).u.copy()
    ug[100:103] = np.nan
    g = compare(IDData(yg, ug), model)
    assert np.isnan(g.y_hat[0][100:103]).all()
    np.testing.assert_allclose(g.y_hat[0][103:], lfilter(B, A, ug[103:]), atol=1e-12)


def test_resid_pools_experiments_without_crossing_a_boundary(three):
    from adaptid.models import ARX, resid

    m = three[0].merge(*three[1:])
    model = ARX(2, 2, 1).fit(m)
    r = resid(m, model, max_lag=10)
    s = 2      # the model's first row
    parts = [(e.y - model.predict(e.y, e.u))[s:] for e in three]
    np.testing.assert_allclose(r.e, np.concatenate(parts), atol=1e-12)
    # oracle acf: the products inside each experiment, over the pooled variance
    mean = np.concatenate(parts).mean()
    c = [p - mean for p in parts]
    ss = sum(p @ p for p in c)
    acf = [sum(p[t:] @ p[:p.size - t] for p in c) / ss for t in range(11)]
    np.testing.assert_allclose(r.autocorrelation["acf"], acf, rtol=1e-12)
    N = sum(p.size for p in c)
    q = N * (N + 2) * sum(acf[t] ** 2 / (N - t) for t in range(1, 11))
    np.testing.assert_allclose(r.autocorrelation["q_stat"], q, rtol=1e-12)
    # cross-correlation at lag 0 and 3 by hand
    uc = [e.u[s:] - np.concatenate([x.u[s:] for x in three]).mean() for e in three]
    den = np.sqrt(sum(x @ x for x in uc) * ss)
    for lag in (0, 3):
        cc = sum(p[lag:] @ x[:x.size - lag] for p, x in zip(c, uc)) / den
        np.testing.assert_allclose(r.cross_correlation[0]["ccf"][10 + lag], cc, rtol=1e-12)
    # the residuals' fit is also the model's own on the stacked rows
    np.testing.assert_allclose(np.sort(r.e), np.sort(model.residuals), atol=1e-10)


# ----------------------------------------------- IV and regularised estimates
def _iv_rows(y, u, na, nb, nk):
    Phi, t = _rows_by_hand(y, u, na, nb, nk)
    Phi[:, :na] *= -1
    return Phi, t


def test_ivx_and_iv4_form_rows_and_filters_inside_each_experiment(three):
    from adaptid.models import iv4, ivx

    m = three[0].merge(*three[1:])
    na, nb, nk = 2, 2, 1
    xs = [lfilter([0, 1.0, 0.5], [1, -1.5, 0.7], e.u) for e in three]
    mx = ivx(m, na, nb, nk, np.concatenate(xs))
    Phi = np.vstack([_iv_rows(e.y, e.u, na, nb, nk)[0] for e in three])
    t = np.concatenate([_iv_rows(e.y, e.u, na, nb, nk)[1] for e in three])
    Z = np.vstack([_iv_rows(x, e.u, na, nb, nk)[0] for x, e in zip(xs, three)])
    np.testing.assert_allclose(mx.theta, np.linalg.solve(Z.T @ Phi, Z.T @ t), rtol=1e-10)
    # iv4, its four stages in NumPy, experiment by experiment
    th = np.linalg.lstsq(Phi, t, rcond=None)[0]

    def iv_step(theta, recs):
        A, B = np.r_[1.0, theta[:na]], np.r_[np.zeros(nk), theta[na:]]
        Zs = np.vstack([_iv_rows(lfilter(B, A, u), u, na, nb, nk)[0] for y, u in recs])
        P = np.vstack([_iv_rows(y, u, na, nb, nk)[0] for y, u in recs])
        tt = np.concatenate([_iv_rows(y, u, na, nb, nk)[1] for y, u in recs])
        return np.linalg.solve(Zs.T @ P, Zs.T @ tt)

    recs = [(e.y, e.u) for e in three]
    th2 = iv_step(th, recs)
    nl = na + nb
    vs = [tt - P @ th2 for P, tt in (_iv_rows(y, u, na, nb, nk) for y, u in recs)]
    V = np.vstack([np.column_stack([v[nl - j - 1: v.size - j - 1] for j in range(nl)]) for v in vs])
    ell = np.linalg.lstsq(-V, np.concatenate([v[nl:] for v in vs]), rcond=None)[0]
    L = np.r_[1.0, ell]
    # stage 4: instruments of the stage-2 model on the unfiltered u, then everything by L
    A2, B2 = np.r_[1.0, th2[:na]], np.r_[np.zeros(nk), th2[na:]]
    P4 = np.vstack([_iv_rows(lfilter(L, 1, y), lfilter(L, 1, u), na, nb, nk)[0] for y, u in recs])
    t4 = np.concatenate([_iv_rows(lfilter(L, 1, y), lfilter(L, 1, u), na, nb, nk)[1]
                         for y, u in recs])
    Z4 = np.vstack([_iv_rows(lfilter(L, 1, lfilter(B2, A2, u)), lfilter(L, 1, u), na, nb, nk)[0]
                    for y, u in recs])
    m4 = iv4(m, na, nb, nk)
    np.testing.assert_allclose(m4.prefilter, L, rtol=1e-10)
    np.testing.assert_allclose(m4.theta, np.linalg.solve(Z4.T @ P4, Z4.T @ t4), rtol=1e-9)


def test_impulseest_stacks_each_experiments_fir_rows(three):
    from adaptid.models import impulseest

    m = three[0].merge(*three[1:])
    n, s2 = 15, 0.01
    est = impulseest(m, n, nk=1, hyperparameters=(1.0, 0.8), noise_variance=s2)
    Phi = np.vstack([_rows_by_hand(e.y, e.u, 0, n, 1)[0] for e in three])
    t = np.concatenate([_rows_by_hand(e.y, e.u, 0, n, 1)[1] for e in three])
    # the regularised solution for the model's prior P (its kernel is tested elsewhere):
    # θ = P Φᵀ (Φ P Φᵀ + σ² I)⁻¹ y, here through the equivalent (ΦᵀΦ + σ² P⁻¹) θ = Φᵀ y
    P = est.prior
    theta = np.linalg.solve(Phi.T @ Phi + s2 * np.linalg.inv(P), Phi.T @ t)
    np.testing.assert_allclose(est.theta, theta, rtol=1e-6, atol=1e-9)


def test_select_order_stacks_each_experiments_rows(three):
    from adaptid.models import select_order

    m = three[0].merge(*three[1:])
    sel = select_order(m, na=[1, 2], nb=[1, 2], nk=[1, 2])
    s = 3                     # the common first row: max(na) = 2, max(nk) + max(nb) - 1 = 3
    rows = [np.arange(s, len(e)) for e in three]
    Phi = np.vstack([np.column_stack([-e.y[r - 1], -e.y[r - 2], e.u[r - 1], e.u[r - 2]])
                     for e, r in zip(three, rows)])
    t = np.concatenate([e.y[r] for e, r in zip(three, rows)])
    res = t - Phi @ np.linalg.lstsq(Phi, t, rcond=None)[0]
    i = int(np.flatnonzero((sel.table["na"] == 2) & (sel.table["nb"] == 2)
                           & (sel.table["nk"] == 1))[0])
    np.testing.assert_allclose(sel.table["loss"][i], res @ res / t.size, rtol=1e-10)
    # model() fits the same rows of each experiment
    model = sel.model((2, 2, 1))
    assert model.residuals.size == t.size and model.n_experiments == 3


def test_sindy_refuses_a_merged_record_and_gaps(three):
    from adaptid.models import SINDy

    with pytest.raises(ValueError, match="X must be an IDData of one experiment"):
        SINDy().fit(three[0].merge(three[1]))
    y = three[0].y.copy()
    y[3] = np.nan
    with pytest.raises(ValueError, match="X must be finite"):
        SINDy().fit(IDData(y, three[0].u))


def test_spectral_estimates_refuse_a_merged_record_and_gaps(three):
    from adaptid.models import etfe, spa

    with pytest.raises(ValueError, match="data must be one experiment"):
        spa(three[0].merge(three[1]))
    y = three[0].y.copy()
    y[3] = np.nan
    with pytest.raises(ValueError, match="y must be finite"):
        etfe(IDData(y, three[0].u))
    from adaptid.models import tfest

    with pytest.raises(ValueError, match="data must be one experiment without NaN gaps"):
        tfest(three[0].merge(three[1]), 2)

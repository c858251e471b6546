"""The recursive pseudo-linear regressions on several experiments and gaps
(issue 34, point 1): ARMAX / OE / BJ / ARMA ``fit_recursive`` on a merged
or gapped record.

The oracles are not the code under test: (a) the single-experiment
recursion run piece by piece, the estimator of each piece built by hand
from the previous piece's final θ and P (``theta0``/``P0``); (b) the merge
of a gapped record's complete runs, cut out by hand; (c) the ELS recursion
of ARMAX written out in NumPy, with its residual lag buffer restarted at
each experiment; (d) the true parameters (Monte Carlo); a SlidingWindowRLS
run over the regressor rows rebuilt in NumPy from the θ track."""

import numpy as np
import pytest
from scipy.signal import lfilter

from adaptid import IDData, KalmanRLS, RLS, SlidingWindowRLS
from adaptid.forgetting import ConstantTrace, Variable
from adaptid.models import ARMA, ARMAX, BJ, OE

# the four structures: (constructor, number of parameters, time series?)
KINDS = {
    "armax": (lambda: ARMAX(2, 2, 1, 1), 5, False),
    "oe": (lambda: OE(2, 2, 1), 4, False),
    "bj": (lambda: BJ(2, 1, 1, 2, 1), 6, False),
    "arma": (lambda: ARMA(2, 1), 3, True),
}


def _record(rng, N, series):
    """One experiment of y = B/F u + C/D e (or an ARMA series)."""
    e = 0.2 * rng.standard_normal(N)
    if series:
        return lfilter([1, 0.4], [1, -1.2, 0.5], e), None
    u = rng.standard_normal(N)
    return lfilter([0, 1.0, 0.5], [1, -1.5, 0.7], u) + lfilter([1, 0.4], [1, -0.5], e), u


def _iddata(y, u):
    return IDData(y) if u is None else IDData(y, u)


def _merged(recs):
    parts = [_iddata(y, u) for y, u in recs]
    return parts[0].merge(*parts[1:])


def _fit(kind, y, u, est):
    make, _, series = KINDS[kind]
    model = make()
    traj = model.fit_recursive(y, est) if series else model.fit_recursive(y, u, est)
    return model, traj


# each estimator: the first piece's, and the next piece's from (θ, P) of the last
ESTIMATORS = {
    "rls": (lambda n: RLS(n), lambda n, th, P: RLS(n, theta0=th, P0=P)),
    "forgetting": (lambda n: RLS(n, forgetting=0.98),
                   lambda n, th, P: RLS(n, forgetting=0.98, theta0=th, P0=P)),
    "kalman": (lambda n: KalmanRLS(n, process_cov=1e-4, noise_var=0.04),
               lambda n, th, P: KalmanRLS(n, process_cov=1e-4, noise_var=0.04, theta0=th,
                                          P0=P)),
    # the diffuse start identifies θ inside the first piece; from then on the
    # recursion is the ordinary one from the exact information, i.e. (θ, P)
    "diffuse": (lambda n: RLS(n, P0="diffuse"), lambda n, th, P: RLS(n, theta0=th, P0=P)),
    "constant_trace": (lambda n: RLS(n, forgetting=ConstantTrace(0.9, trace=10.0 * n)),
                       lambda n, th, P: RLS(n, forgetting=ConstantTrace(0.9, trace=10.0 * n),
                                            theta0=th, P0=P)),
    "variable": (lambda n: RLS(n, forgetting=Variable(0.95, sigma0=0.2, memory=200)),
                 lambda n, th, P: RLS(n, forgetting=Variable(0.95, sigma0=0.2, memory=200),
                                      theta0=th, P0=P)),
}


def _piecewise(kind, recs, est_name):
    """(a): the single-experiment recursion on each record in turn, the estimator
    of each built from the previous one's final θ (the track's last row, before
    root reflection) and P."""
    _, n, _ = KINDS[kind]
    first, nxt = ESTIMATORS[est_name]
    Th, E, Lk, th, P = [], [], [], None, None
    for i, (y, u) in enumerate(recs):
        est = first(n) if i == 0 else nxt(n, th, P)
        model, traj = _fit(kind, y, u, est)
        Th.append(traj.theta)
        E.append(traj.error)
        Lk.append(traj.forgetting)
        th, P = traj.theta[-1].copy(), model.P
        assert np.all(np.isfinite(P))
    return np.vstack(Th), np.concatenate(E), Lk


@pytest.mark.parametrize("kind", list(KINDS))
@pytest.mark.parametrize("est_name", ["rls", "forgetting", "kalman"])
def test_merged_equals_pieces_with_state_handed_on(rng, kind, est_name):
    _, n, series = KINDS[kind]
    recs = [_record(rng, N, series) for N in (300, 200, 250)]
    Th, E, _ = _piecewise(kind, recs, est_name)
    model, traj = _fit(kind, _merged(recs), None, ESTIMATORS[est_name][0](n))
    # the estimator state is handed on through P = U D Uᵀ, refactorised by
    # the next estimator: a rounding difference, 1e-12 on θ of order 1
    np.testing.assert_allclose(traj.theta, Th, rtol=0, atol=1e-12)
    np.testing.assert_allclose(traj.error, E, rtol=0, atol=1e-12)
    s = {"armax": 2, "oe": 2, "bj": 2, "arma": 2}[kind]   # first row of a piece: max lag
    rows = [N - s for N in (300, 200, 250)]
    np.testing.assert_array_equal(traj.meta["row_bounds"], np.r_[0, np.cumsum(rows)])
    offsets = np.r_[0, np.cumsum([300, 200, 250])]
    np.testing.assert_array_equal(
        traj.meta["index"], np.concatenate([np.arange(o + s, o + N) for o, N in
                                            zip(offsets, (300, 200, 250))]))
    assert traj.meta["n_dropped"] == model.n_dropped == 0
    assert model.n_experiments == traj.meta["n_experiments"] == 3


@pytest.mark.parametrize("kind", ["armax", "bj"])
@pytest.mark.parametrize("est_name", ["diffuse", "constant_trace", "variable"])
def test_merged_equals_pieces_other_estimators(rng, kind, est_name):
    _, n, series = KINDS[kind]
    recs = [_record(rng, N, series) for N in (250, 150, 200)]
    Th, E, Lk = _piecewise(kind, recs, est_name)
    _, traj = _fit(kind, _merged(recs), None, ESTIMATORS[est_name][0](n))
    np.testing.assert_allclose(traj.theta, Th, rtol=0, atol=1e-12)
    np.testing.assert_allclose(traj.error, E, rtol=0, atol=1e-12)
    if est_name == "diffuse":
        ident = traj.identified
        assert not ident[0] and ident[-1] and ident[248:].all()
    else:   # the λₖ the strategy applied, over all pieces
        np.testing.assert_allclose(traj.forgetting, np.concatenate(Lk), rtol=0, atol=1e-12)


@pytest.mark.parametrize("kind", list(KINDS))
def test_gapped_record_equals_merge_of_its_runs(rng, kind):
    _, n, series = KINDS[kind]
    y, u = _record(rng, 700, series)
    y = y.copy()
    y[[200, 201, 450]] = np.nan
    if u is not None:
        u = u.copy()
        u[[600]] = np.nan                        # a gap in the input splits as well
    runs = [(0, 200), (202, 450), (451, 600), (601, 700)] if u is not None else \
        [(0, 200), (202, 450), (451, 700)]
    pieces = [(y[a:b], None if u is None else u[a:b]) for a, b in runs]
    est = RLS(n, forgetting=0.99)
    gap_model, gap = _fit(kind, y, u, est)
    ref_model, ref = _fit(kind, _merged(pieces), None, est)
    np.testing.assert_array_equal(gap.theta, ref.theta)
    np.testing.assert_array_equal(gap.error, ref.error)
    np.testing.assert_array_equal(gap.meta["row_bounds"], ref.meta["row_bounds"])
    # the rows' positions: in the gapped record, each run at its own offset
    pos = np.concatenate([np.arange(a, b) for a, b in runs])
    np.testing.assert_array_equal(gap.meta["index"], pos[ref.meta["index"]])
    assert not np.isnan(y[gap.meta["index"]]).any()
    # the rows lost: the NaN samples and the max lag (2) of rows to restart after each
    n_nan = 3 + (u is not None)
    assert gap.meta["n_dropped"] == gap_model.n_dropped == n_nan + 2 * (len(runs) - 1)
    np.testing.assert_allclose(gap_model.theta, ref_model.theta, rtol=0, atol=1e-12)
    np.testing.assert_allclose(gap_model.residuals, ref_model.residuals, rtol=0, atol=1e-12)
    # fit reports the same rows left out; summary says so
    fit_model = KINDS[kind][0]()
    fit_model.fit(y, refine=False) if series else fit_model.fit(y, u, refine=False)
    assert fit_model.n_dropped == gap_model.n_dropped
    assert gap_model.summary().stats["rows left out (NaN)"] == gap_model.n_dropped


def test_armax_els_lag_buffers_written_out(rng):
    """(c): RELS for ARMAX(2, 2, 1, 1) in NumPy, sample by sample: the residual
    lags ε̄ restart at 0 in each experiment, θ and P run on."""
    Ns = (120, 80, 100)
    recs = [_record(rng, N, False) for N in Ns]
    P0 = 100.0
    _, traj = _fit("armax", _merged(recs), None, RLS(5, P0=P0))
    theta, P = np.zeros(5), P0 * np.eye(5)
    Th, E = [], []
    for y, u in recs:
        eps = np.zeros(y.size)                       # ε̄ of this experiment, 0 before it
        for k in range(2, y.size):                   # rows from the largest lag s = 2
            phi = np.array([-y[k - 1], -y[k - 2], u[k - 1], u[k - 2],
                            eps[k - 1] if k - 1 >= 2 else 0.0])
            e = y[k] - phi @ theta
            K = P @ phi / (1.0 + phi @ P @ phi)
            theta = theta + K * e
            P = P - np.outer(K, phi @ P)
            P = 0.5 * (P + P.T)
            eps[k] = y[k] - phi @ theta              # a-posteriori residual
            Th.append(theta.copy())
            E.append(e)
    # the covariance form vs the kernel's U-D (Bierman) form: rounding only,
    # amplified by P0 = 100 in the first rows
    np.testing.assert_allclose(traj.theta, np.array(Th), rtol=0, atol=1e-9)
    np.testing.assert_allclose(traj.error, np.array(E), rtol=0, atol=1e-9)
    # the regressor rows the recursion reports: ε̄ column 0 at each experiment's first row
    rows = traj.meta["regressors"]
    assert np.all(rows[traj.meta["row_bounds"][:-1], 4] == 0.0)


def test_window_runs_across_experiments(rng):
    """A SlidingWindowRLS's window holds rows of two experiments at a boundary:
    the track equals the core SlidingWindowRLS run over the regressor rows
    rebuilt in NumPy from the θ track (ε̄ restarted per experiment)."""
    Ns, M = (200, 150, 180), 40
    recs = [_record(rng, N, False) for N in Ns]
    _, traj = _fit("armax", _merged(recs), None, SlidingWindowRLS(5, M, P0=1e3))
    rows, ys, o = [], [], 0
    for y, u in recs:
        eps = np.zeros(y.size)
        for k in range(2, y.size):
            phi = np.array([-y[k - 1], -y[k - 2], u[k - 1], u[k - 2],
                            eps[k - 1] if k - 1 >= 2 else 0.0])
            eps[k] = y[k] - phi @ traj.theta[o]
            rows.append(phi)
            ys.append(y[k])
            o += 1
    rows = np.array(rows)
    np.testing.assert_allclose(traj.meta["regressors"], rows, rtol=0, atol=1e-12)
    ref = SlidingWindowRLS(5, M, P0=1e3).run(rows, np.array(ys))
    np.testing.assert_allclose(traj.theta, ref.theta, rtol=0, atol=1e-9)


def test_three_experiments_consistent(rng):
    """(d): the final θ of RELS over three experiments is near the truth
    (Monte Carlo over 20 records; ELS is consistent as 1/C − 1/2 is SPR)."""
    truth = np.array([-1.5, 0.7, 1.0, 0.5, 0.4])   # a1 a2 b0 b1 c1 of ARMAX(2, 2, 1, 1)
    finals = []
    for _ in range(20):
        recs = []
        for N in (1500, 1000, 1200):
            u = rng.standard_normal(N)
            e = 0.3 * rng.standard_normal(N)
            y = lfilter([0, 1.0, 0.5], [1, -1.5, 0.7], u) + lfilter([1, 0.4], [1, -1.5, 0.7], e)
            recs.append((y, u))
        model = ARMAX(2, 2, 1, 1)
        model.fit_recursive(_merged(recs))
        finals.append(model.theta)
    finals = np.array(finals)
    # bias: the Monte Carlo mean within 0.02 of the truth; spread: each run within 0.1
    np.testing.assert_allclose(finals.mean(axis=0), truth, atol=0.02)
    assert np.abs(finals - truth).max() < 0.1


def test_merged_time_and_refine(rng):
    recs = [_record(rng, N, False) for N in (300, 250)]
    parts = [IDData(y, u, 0.5) for y, u in recs]
    data = parts[0].merge(parts[1])
    model = OE(2, 2, 1)
    traj = model.fit_recursive(data, refine=True)
    np.testing.assert_allclose(traj.time, np.r_[np.arange(2, 300), np.arange(2, 250)] * 0.5)
    # the refinement minimises the same per-experiment criterion as fit
    ref = OE(2, 2, 1).fit(data)
    np.testing.assert_allclose(model.theta, ref.theta, atol=1e-6)
    assert model.residuals.size == 298 + 248
    assert model.summary().stats["experiments"] == 2

"""NARX with FROLS: exact recovery, brute-force least squares, sysidentpy's FROLS (issue 35)."""

import numpy as np
import pytest

from adaptid import IDData
from adaptid.models import NARX, compare, resid
from adaptid.models.nonlinear._basis import MonomialBasis, multisets
from adaptid.models.nonlinear._frols import criteria


def miso_system(N=600, seed=0, noise=0.0):
    """y(k) = 0.2 + 0.5 y(k-1) + 0.8 u1(k-1) - 0.3 u2(k-2) y(k-1) + 0.1 u2(k-1)^2 + e(k)."""
    rng = np.random.default_rng(seed)
    u = rng.uniform(-1, 1, (N, 2))
    e = noise * rng.standard_normal(N)
    y = np.zeros(N)
    y[:2] = rng.uniform(0.2, 0.6, 2)  # nonzero start: see the sysidentpy test
    for k in range(2, N):
        y[k] = (0.2 + 0.5 * y[k - 1] + 0.8 * u[k - 1, 0] - 0.3 * u[k - 2, 1] * y[k - 1]
                + 0.1 * u[k - 1, 1] ** 2 + e[k])
    return y, u


TRUE = {"1": 0.2, "y(k-1)": 0.5, "u1(k-1)": 0.8, "u2(k-2)*y(k-1)": -0.3, "u2(k-1)^2": 0.1}


# --------------------------------------------------------------------------- basis
def test_basis_products_equal_the_explicit_candidate_matrix():
    rng = np.random.default_rng(1)
    X = rng.standard_normal((50, 4))
    for D in (1, 2, 3):
        b = MonomialBasis(X, D)
        P = b.columns(np.arange(b.M))
        assert b.M == multisets(4, D).shape[0]
        w = rng.standard_normal(50)
        np.testing.assert_allclose(b.project(w), P.T @ w, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(b.sq_norms(), (P * P).sum(0), rtol=1e-12)
        # the same in row blocks (the memory budget forces 1-row... few-row blocks)
        bb = MonomialBasis(X, D, budget=8 * 7 * b._prefixes.shape[0])
        assert bb._Q is None
        np.testing.assert_allclose(bb.project(w), P.T @ w, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(bb.sq_norms(), (P * P).sum(0), rtol=1e-12)


def test_candidate_count_of_the_benchmark():
    # 8 output lags + 2 inputs x 8 lags = 24 base variables, degree 3: C(27, 3) = 2925
    assert multisets(24, 3).shape[0] == 2925


# ------------------------------------------------------------------ exact recovery
@pytest.mark.parametrize("criterion", ["aic", "bic", "fpe", "lilc"])
def test_noise_free_system_recovered_exactly(criterion):
    y, u = miso_system()
    m = NARX(2, 2, 2, criterion=criterion).fit(IDData(y, u))
    assert set(m.terms) == set(TRUE)
    np.testing.assert_allclose([TRUE[t] for t in m.terms], m.theta, rtol=0, atol=1e-10)
    assert m.max_lag == 2 and m.index[0] == 2 and m.residuals.size == y.size - 2
    np.testing.assert_allclose(np.sum(m.err), 1.0, atol=1e-10)
    # free run from the first L measured outputs and k-step prediction are exact
    np.testing.assert_allclose(m.simulate(u, y0=y), y, atol=1e-10)
    np.testing.assert_allclose(m.predict(y, u, k=5), y, atol=1e-10)


def test_noise_free_cubic_with_given_n_terms_and_delay():
    rng = np.random.default_rng(3)
    N = 500
    u = rng.uniform(-1, 1, N)
    y = np.zeros(N)
    for k in range(3, N):
        y[k] = 0.6 * y[k - 1] - 0.1 * y[k - 2] + u[k - 2] + 0.2 * u[k - 3] ** 3 - 0.1 * y[k - 1] ** 2 * u[k - 2]
    m = NARX(2, 2, 3, nk=2, n_terms=5).fit(y, u)
    want = {"y(k-1)": 0.6, "y(k-2)": -0.1, "u(k-2)": 1.0, "u(k-3)^3": 0.2,
            "u(k-2)*y(k-1)^2": -0.1}
    assert set(m.terms) == set(want)
    np.testing.assert_allclose([want[t] for t in m.terms], m.theta, atol=1e-10)
    assert m.max_lag == 3


def test_mimo_one_term_set_per_output():
    rng = np.random.default_rng(4)
    N = 400
    u = rng.uniform(-1, 1, N)
    y = np.zeros((N, 2))
    for k in range(1, N):
        y[k, 0] = 0.5 * y[k - 1, 0] + u[k - 1] + 0.2 * y[k - 1, 1] * u[k - 1]
        y[k, 1] = 0.3 * y[k - 1, 1] - 0.4 * y[k - 1, 0] ** 2 + 0.1
    d = IDData(y, u, y_names=["a", "b"], u_names="f")
    m = NARX(1, 1, 2).fit(d)
    assert set(m.terms[0]) == {"a(k-1)", "f(k-1)", "f(k-1)*b(k-1)"}
    assert set(m.terms[1]) == {"b(k-1)", "a(k-1)^2", "1"}
    np.testing.assert_allclose(m.simulate(d), y, atol=1e-10)
    assert m.predict(d, k=2).shape == (N, 2)
    assert "a(k) = " in m.to_equations() and "\nb(k) = " in m.to_equations()


def test_time_series_without_input():
    N = 300
    y = np.zeros(N)
    y[0] = 0.3
    for k in range(1, N):
        y[k] = 3.7 * y[k - 1] * (1 - y[k - 1])  # the logistic map: y(k-1) - y(k-1)^2
    m = NARX(1, 0, 2).fit(y)
    # FROLS takes the constant first here (the largest ERR), so it needs all three
    # candidates; the constant's estimate is then zero
    th = dict(zip(m.terms, m.theta))
    assert set(th) == {"1", "y(k-1)", "y(k-1)^2"}
    np.testing.assert_allclose([th["1"], th["y(k-1)"], th["y(k-1)^2"]], [0, 3.7, -3.7],
                               atol=1e-10)
    np.testing.assert_allclose(m.predict(y, k=1), y, atol=1e-12)


# --------------------------------------------------------- least squares and criteria
def test_theta_and_stderr_equal_brute_force_lstsq():
    y, u = miso_system(noise=0.05)
    m = NARX(2, 2, 2, n_terms=7).fit(y, u)
    rows = np.arange(2, y.size)
    base = {"1": np.ones(rows.size), "y(k-1)": y[rows - 1], "y(k-2)": y[rows - 2],
            "u1(k-1)": u[rows - 1, 0], "u1(k-2)": u[rows - 2, 0],
            "u2(k-1)": u[rows - 1, 1], "u2(k-2)": u[rows - 2, 1]}

    def column(term):
        out = np.ones(rows.size)
        for f in term.split("*"):
            name, _, p = f.partition("^")
            out = out * base[name] ** (int(p) if p else 1)
        return out

    Phi = np.column_stack([column(t) for t in m.terms])
    theta, *_ = np.linalg.lstsq(Phi, y[rows], rcond=None)
    r = y[rows] - Phi @ theta
    s2 = r @ r / (rows.size - Phi.shape[1])
    se = np.sqrt(np.diag(s2 * np.linalg.inv(Phi.T @ Phi)))
    np.testing.assert_allclose(m.theta, theta, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(m.stderr, se, rtol=1e-8)
    np.testing.assert_allclose(m.residuals, r, atol=1e-12)
    # ERR: each term's share of y'y after orthogonalising against the earlier ones
    yy = y[rows] @ y[rows]
    prev = 0.0
    for d in range(1, len(m.terms) + 1):
        t, *_ = np.linalg.lstsq(Phi[:, :d], y[rows], rcond=None)
        ssr = np.sum((y[rows] - Phi[:, :d] @ t) ** 2)
        np.testing.assert_allclose(m.err[d - 1], (yy - ssr) / yy - prev, atol=1e-12)
        prev = (yy - ssr) / yy


def test_criterion_is_the_global_minimum_over_the_path():
    y, u = miso_system(noise=0.05, N=800)
    m = NARX(2, 2, 2, criterion="bic", max_terms=12).fit(y, u)
    path = m.result.path
    N = y.size - 2
    d = np.arange(1, path["ssr"].size + 1)
    V = path["ssr"] / N
    np.testing.assert_allclose(path["aic"], N * np.log(V) + 2 * d)
    np.testing.assert_allclose(path["bic"], N * np.log(V) + d * np.log(N))
    np.testing.assert_allclose(path["fpe"], N * np.log(V) + N * np.log((N + d) / (N - d)))
    np.testing.assert_allclose(path["lilc"], N * np.log(V) + 2 * d * np.log(np.log(N)))
    assert path["chosen"] == int(np.argmin(path["bic"])) + 1 == len(m.terms)
    assert path["ssr"].size == 12
    # with noise the true terms are still the ones chosen
    assert set(TRUE) <= set(m.terms)
    # the path's SSR is the least-squares loss of the nested models
    np.testing.assert_allclose(path["ssr"][len(m.terms) - 1], m.residuals @ m.residuals,
                               rtol=1e-10)


def test_loss_floor_keeps_noise_free_models_exact():
    c = criteria([1.0, 1e-30, 1e-31], 100, 1.0)
    assert int(np.argmin(c["aic"])) == 1


# ------------------------------------------------------------------------ sysidentpy
def test_same_as_sysidentpy_frols_with_least_squares():
    """sysidentpy 0.9 FROLS, order_selection=False, LeastSquares, on the same record.

    sysidentpy builds the same candidates in the same order (the constant, then
    combinations with replacement of [y(k-1), y(k-2), x1(k-1), x1(k-2), x2(k-1),
    x2(k-2)]) over the same rows k = max lag … N-1, centres nothing and computes
    ERR = (w'y)^2 / (w'w y'y) + eps (eps = 2.2e-16 added to every value) by
    Householder QR; we match terms and order, ERR to 1e-10 and θ to 1e-9.
    The record starts from nonzero outputs: sysidentpy 0.9's ``house()`` takes
    sign(x[0]) = 0 when a chosen column's first entry is exactly 0 (e.g. y(k-1)
    of a record starting at y = 0) and its ERR values are then wrong (they can
    sum to more than 1).
    """
    sysidentpy = pytest.importorskip("sysidentpy")
    from sysidentpy.basis_function import Polynomial
    from sysidentpy.model_structure_selection import FROLS
    from sysidentpy.parameter_estimation import LeastSquares

    y, u = miso_system(noise=0.05, N=500, seed=7)
    for n_terms, degree in ((6, 2), (9, 3)):
        ref = FROLS(order_selection=False, n_terms=n_terms, ylag=2, xlag=[[1, 2], [1, 2]],
                    basis_function=Polynomial(degree=degree), estimator=LeastSquares())
        ref.fit(X=u, y=y[:, None])
        m = NARX(2, 2, degree, n_terms=n_terms).fit(y, u)
        # base variable i (1-based) of ours -> sysidentpy's code
        codes = np.array([0, 1001, 1002, 2001, 2002, 3001, 3002])
        ours = [tuple(sorted(codes[c], reverse=True)) for c in m.result.combos]
        theirs = [tuple(row) for row in ref.final_model]
        assert ours == theirs, sysidentpy.__version__
        np.testing.assert_allclose(m.err, ref.err[:n_terms], rtol=0, atol=1e-10)
        np.testing.assert_allclose(m.theta, ref.theta.ravel(), rtol=1e-9, atol=1e-12)


# ------------------------------------------------------------------------- workflow
def test_compare_and_resid_accept_it():
    y, u = miso_system(noise=0.02, N=1000)
    d = IDData(y, u)
    est, val = d.split(0.5)
    m = NARX(2, 2, 2).fit(est)
    res = compare(val, m)
    np.testing.assert_allclose(res.y_hat[0], m.simulate(val.u, y0=val.y))
    assert res.fit[0] > 90
    res1 = compare(val, m, k=1)
    np.testing.assert_allclose(res1.y_hat[0], m.predict(val, k=1))
    r = resid(val, m)
    assert r.start == 2 and r.white


def test_summary_frame_plot_equations():
    pytest.importorskip("pandas")
    y, u = miso_system(noise=0.02)
    m = NARX(2, 2, 2, n_terms=5).fit(IDData(y, u))
    s = m.summary()
    text = str(s)
    for t in m.terms:
        assert t in text
    assert "ERR" in text and "AIC" in text and "<table>" in s._repr_html_()
    assert s["terms"] == 5
    np.testing.assert_allclose(s.params[:, 6], m.err)
    np.testing.assert_allclose(s.params[:, 1], m.stderr)
    assert list(s.to_frame().columns)[-1] == "ERR"
    f = m.to_frame()
    assert list(f.index) == list(m.terms)
    np.testing.assert_allclose(f["estimate"], m.theta)
    np.testing.assert_allclose(f["P>|t|"], m.result.pvalues)
    eq = m.to_equations(precision=4)
    assert eq.startswith("y(k) = ")
    assert f"{abs(m.theta[1]):.4g} {m.terms[1]}" in eq
    mpl = pytest.importorskip("matplotlib")
    mpl.use("Agg")
    from matplotlib.figure import Figure
    assert isinstance(m.plot(), Figure)
    m2 = NARX(2, 2, 2).fit(IDData(y, u))
    assert isinstance(m2.result.plot(), Figure)
    import matplotlib.pyplot as plt
    plt.close("all")


def test_errors_name_the_argument():
    y, u = miso_system()
    with pytest.raises(ValueError, match="degree must be an integer >= 1"):
        NARX(1, 1, 0)
    with pytest.raises(ValueError, match="criterion must be"):
        NARX(1, 1, criterion="hqc")
    with pytest.raises(ValueError, match="n_terms must be"):
        NARX(1, 1, n_terms=0)
    with pytest.raises(ValueError, match="n_terms must be <= 6"):
        NARX(1, 1, 2, n_terms=7).fit(y, u[:, 0])
    with pytest.raises(ValueError, match="ylag \\+ ulag must be"):
        NARX(0, 0).fit(y, u)
    m = NARX(1, 1).fit(y, u[:, 0])
    with pytest.raises(ValueError, match="u must be with 1 input"):
        m.predict(y, u, k=1)
    with pytest.raises(ValueError, match="k must be an integer >= 1"):
        m.predict(y, u[:, 0], k=0)
    from adaptid.models import NotFittedError
    with pytest.raises(NotFittedError):
        NARX(1, 1).simulate(u[:, 0])


# --------------------------------------------------------------------------- NARMAX
def narmax_system(N=4000, seed=5, c=0.6):
    """y(k) = 0.5 y(k-1) + u(k-1) - 0.3 u(k-1) y(k-1) + e(k) + c e(k-1)."""
    rng = np.random.default_rng(seed)
    u = rng.uniform(-1, 1, N)
    e = 0.1 * rng.standard_normal(N)
    y = np.zeros(N)
    for k in range(1, N):
        y[k] = 0.5 * y[k - 1] + u[k - 1] - 0.3 * u[k - 1] * y[k - 1] + e[k] + c * e[k - 1]
    return y, u


def test_narmax_noise_terms_by_extended_least_squares():
    y, u = narmax_system()
    m = NARX(1, 1, 2, n_terms=3, noise_lags=1).fit(y, u)
    assert m.terms[:3] == ("u(k-1)", "y(k-1)", "u(k-1)*y(k-1)") and m.terms[3] == "e(k-1)"
    assert m.result.n_process == 3 and m.err.size == 3 and m.result.iterations > 1
    # estimates near the truth (4000 samples, sigma_e = 0.1: a few standard errors)
    np.testing.assert_allclose(m.theta, [1.0, 0.5, -0.3, 0.6], atol=4 * m.stderr.max() + 0.01)
    # the least squares without the noise term is biased on y(k-1)
    plain = NARX(1, 1, 2, n_terms=3).fit(y, u)
    assert abs(plain.theta[1] - 0.5) > abs(m.theta[1] - 0.5)
    # the one-step predictor: eps(t) = y(t) - process(t) - c eps(t-1), eps = 0 before row 1
    th = dict(zip(m.terms, m.theta))
    eps = np.zeros(y.size)
    yhat = y.copy()
    for t in range(1, y.size):
        proc = th["u(k-1)"] * u[t - 1] + th["y(k-1)"] * y[t - 1] \
            + th["u(k-1)*y(k-1)"] * u[t - 1] * y[t - 1]
        yhat[t] = proc + th["e(k-1)"] * eps[t - 1]
        eps[t] = y[t] - yhat[t]
    np.testing.assert_allclose(m.predict(y, u, k=1), yhat, atol=1e-12)
    # at convergence the fit's residuals are these one-step errors
    np.testing.assert_allclose(m.residuals, eps[1:], atol=1e-7)
    # beyond the noise lags the k-step prediction is the process part run from the data
    np.testing.assert_allclose(m.predict(y, u, k=y.size), m.simulate(u, y0=y), atol=1e-12)
    # and the noise term whitens the one-step errors
    from adaptid.models import resid
    assert resid((y, u), m).white and not resid((y, u), plain).white
    s = str(m.summary())
    assert "e(k-1)" in s and "noise terms" in s
    assert "e(k-1)" in m.to_equations()


def test_narmax_two_step_prediction_by_hand():
    y, u = narmax_system(N=300)
    m = NARX(1, 1, 2, n_terms=3, noise_lags=2).fit(y, u)
    th = dict(zip(m.terms, m.theta))
    eps = y - m.predict(y, u, k=1)

    def proc(yp, t):
        return th["u(k-1)"] * u[t - 1] + th["y(k-1)"] * yp + th["u(k-1)*y(k-1)"] * u[t - 1] * yp

    want = y.copy()
    for t in range(2, y.size):
        y1 = proc(y[t - 2], t - 1) + th["e(k-1)"] * eps[t - 2] + th["e(k-2)"] * (
            eps[t - 3] if t >= 3 else 0.0)
        want[t] = proc(y1, t) + th["e(k-2)"] * eps[t - 2]
    np.testing.assert_allclose(m.predict(y, u, k=2)[2:], want[2:], atol=1e-12)


def test_several_experiments_are_stacked_without_crossing_lags():
    y1, u1 = miso_system(N=300, seed=1)
    y2, u2 = miso_system(N=250, seed=2)
    m = NARX(2, 2, 2, n_terms=5).fit([IDData(y1, u1), IDData(y2, u2)])
    assert set(m.terms) == set(TRUE)
    np.testing.assert_allclose([TRUE[t] for t in m.terms], m.theta, atol=1e-10)
    assert m.residuals.size == 298 + 248
    np.testing.assert_array_equal(m.index, np.r_[np.arange(2, 300), np.arange(2, 250)])
    # the stacked fit is the least squares on both records' rows
    one = NARX(2, 2, 2, n_terms=5).fit(IDData(y1, u1))
    assert "fit % (simulation, estimation)" not in m.summary().stats
    assert "fit % (simulation, estimation)" in one.summary().stats
    # NARMAX: the lagged residuals restart with each record
    yn1, un1 = narmax_system(N=1500, seed=1)
    yn2, un2 = narmax_system(N=1500, seed=2)
    mm = NARX(1, 1, 2, n_terms=3, noise_lags=1).fit([IDData(yn1, un1), IDData(yn2, un2)])
    np.testing.assert_allclose(mm.theta, [1.0, 0.5, -0.3, 0.6], atol=0.06)
    with pytest.raises(ValueError, match=r"data\[1\] must be a record with 1 output"):
        NARX(1, 1).fit([IDData(y1, u1), IDData(np.c_[y2, y2], u2)])


def test_fewer_independent_candidates_than_n_terms_warns():
    from adaptid._exceptions import AdaptidWarning

    rng = np.random.default_rng(0)
    u = np.sign(rng.standard_normal(200))          # binary: u^2 is the constant
    y = np.zeros(200)
    for k in range(1, 200):
        y[k] = 0.5 * y[k - 1] + u[k - 1]
    with pytest.warns(AdaptidWarning, match="only 5 of n_terms=6"):
        m = NARX(1, 1, 2, n_terms=6).fit(y, u)
    assert len(m.terms) == 5
    assert not {"1", "u(k-1)^2"} <= set(m.terms)


def test_row_blocks_give_the_same_fit(monkeypatch):
    """A prefix-product matrix over the memory budget is rebuilt in row blocks."""
    import adaptid.models.nonlinear._basis as basis

    y, u = miso_system(noise=0.05, N=700)
    full = NARX(3, 3, 3, n_terms=8).fit(y, u)
    monkeypatch.setattr(basis, "Q_BUDGET", 64 * 1024)
    blocked = NARX(3, 3, 3, n_terms=8).fit(y, u)
    assert blocked.terms == full.terms
    np.testing.assert_allclose(blocked.err, full.err, rtol=1e-12)
    np.testing.assert_allclose(blocked.theta, full.theta, rtol=1e-12)

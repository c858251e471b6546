"""NARX after selection: fit_recursive and RecursiveNARX (issue 35, point 2).

Oracles: the closed form of each recursion's final estimate solved directly by
``numpy.linalg.lstsq`` (RLS with prior P0 = ridge least squares; forgetting =
exponentially weighted ridge; a window = ridge on the last M rows), and the
step-by-step object against its own compiled run (bit for bit, the contract
of every streaming object).
"""

import numpy as np
import pytest

import adaptid
from adaptid import IDData
from adaptid.models import NARX, RecursiveNARX


def system(N=600, seed=0, noise=0.02, drift=False):
    """y(k) = 0.2 + a(k) y(k-1) + 0.8 u1(k-1) - 0.3 u2(k-2) y(k-1) + 0.1 u2(k-1)^2 + e."""
    rng = np.random.default_rng(seed)
    u = rng.uniform(-1, 1, (N, 2))
    y = np.zeros(N)
    y[:2] = 0.3
    for k in range(2, N):
        a = 0.5 + (0.2 if drift and k > N // 2 else 0.0)
        y[k] = (0.2 + a * y[k - 1] + 0.8 * u[k - 1, 0] - 0.3 * u[k - 2, 1] * y[k - 1]
                + 0.1 * u[k - 1, 1] ** 2 + noise * rng.standard_normal())
    return y, u


def design(m, y, u):
    """The selected terms' regressors on rows L … N−1, built from the term names."""
    L = m.max_lag
    k = np.arange(L, y.size)
    sig = {"y": lambda j: y[k - j], "u1": lambda j: u[k - j, 0], "u2": lambda j: u[k - j, 1]}
    cols = []
    for t in m.terms:
        col = np.ones(k.size)
        if t != "1":
            for f in t.split("*"):
                base, _, p = f.partition("^")
                name, lag = base[:-1].split("(k-")
                col = col * sig[name](int(lag)) ** int(p or 1)
        cols.append(col)
    return np.column_stack(cols), y[L:]


def ridge(Phi, y, P0, w=None, prior_weight=1.0):
    """argmin Σ w_k (y_k − φ_kᵀθ)² + prior_weight θᵀθ / P0, by lstsq of a stacked system."""
    w = np.ones(y.size) if w is None else w
    sw = np.sqrt(w)
    A = np.vstack([Phi * sw[:, None], np.sqrt(prior_weight / P0) * np.eye(Phi.shape[1])])
    b = np.concatenate([y * sw, np.zeros(Phi.shape[1])])
    return np.linalg.lstsq(A, b, rcond=None)[0]


@pytest.fixture(scope="module")
def fitted():
    y, u = system()
    return NARX(2, 2, 2, n_terms=5).fit(y, u), y, u


# ------------------------------------------------------------------ fit_recursive
def test_rls_final_estimate_is_the_ridge_solution(fitted):
    m, y, u = fitted
    tr = m.fit_recursive(y, u)
    Phi, t = design(m, y, u)
    assert tr.names == m.terms and tr.theta.shape == (y.size - 2, 5)
    np.testing.assert_array_equal(tr.meta["index"], np.arange(2, y.size))
    np.testing.assert_allclose(tr.theta[-1], ridge(Phi, t, 1e4), rtol=1e-9, atol=1e-11)
    np.testing.assert_allclose(tr.theta[-1], m.theta, atol=1e-3)  # the prior's pull only
    # the a-priori errors are y − φᵀθ_{k−1}
    np.testing.assert_allclose(tr.error[1:], t[1:] - (Phi[1:] * tr.theta[:-1]).sum(1),
                               atol=1e-12)
    theta_before = m.theta.copy()
    assert np.array_equal(m.theta, theta_before)  # the batch fit is kept


def test_forgetting_tracks_a_drift_and_is_weighted_ridge():
    y, u = system(N=1200, drift=True)
    m = NARX(2, 2, 2, n_terms=5).fit(y, u)
    lam = 0.98
    tr = m.fit_recursive(y, u, forgetting=lam)
    Phi, t = design(m, y, u)
    n = t.size
    w = lam ** np.arange(n - 1, -1, -1.0)
    np.testing.assert_allclose(tr.theta[-1], ridge(Phi, t, 1e4, w, lam ** n), rtol=1e-8)
    assert abs(dict(zip(m.terms, tr.theta[-1]))["y(k-1)"] - 0.7) < 0.05


def test_window_by_name_and_an_instance_copied(fitted):
    m, y, u = fitted
    M = 150
    tr = m.fit_recursive(y, u, "window", window=M)
    Phi, t = design(m, y, u)
    np.testing.assert_allclose(tr.theta[-1], ridge(Phi[-M:], t[-M:], 1e4), rtol=1e-7,
                               atol=1e-10)
    est = adaptid.KalmanRLS(5, process_cov=1e-6, P0=100.0)
    tk = m.fit_recursive(y, u, est)
    assert est.n_updates == 0 and m.estimators[0].n_updates == y.size - 2
    ref = adaptid.KalmanRLS(5, process_cov=1e-6, P0=100.0).run(Phi, t)
    np.testing.assert_array_equal(tk.theta, ref.theta)
    tl = m.fit_recursive(y, u, "nlms", step=0.5)
    np.testing.assert_array_equal(tl.theta, adaptid.NLMS(5, step=0.5).run(Phi, t).theta)


def test_fit_recursive_refusals(fitted):
    m, y, u = fitted
    with pytest.raises(ValueError, match="estimator must be an estimator with n_params=5"):
        m.fit_recursive(y, u, adaptid.RLS(3))
    with pytest.raises(TypeError, match="options"):
        m.fit_recursive(y, u, adaptid.RLS(5), forgetting=0.9)
    with pytest.raises(TypeError, match="estimator"):
        m.fit_recursive(y, u, object())
    with pytest.raises(ValueError, match="data must be a record with 1 output"):
        m.fit_recursive(IDData(np.c_[y, y], u))
    mn = NARX(1, 1, 2, n_terms=2, noise_lags=1).fit(y, u)
    with pytest.raises(ValueError, match="noise_lags"):
        RecursiveNARX(mn)
    with pytest.raises(ValueError, match="estimator must be an RLS, SlidingWindowRLS"):
        mn.fit_recursive(y, u, "lms", step=0.1)
    with pytest.raises(ValueError, match="data must be one record for a NARMAX"):
        mn.fit_recursive([IDData(y, u), IDData(y, u)])


def test_mimo_and_several_experiments():
    rng = np.random.default_rng(4)
    N = 500
    u = rng.uniform(-1, 1, N)
    y = np.zeros((N, 2))
    for k in range(1, N):
        y[k, 0] = 0.5 * y[k - 1, 0] + u[k - 1] + 0.2 * y[k - 1, 1] * u[k - 1]
        y[k, 1] = 0.3 * y[k - 1, 1] - 0.4 * y[k - 1, 0] ** 2 + 0.1
    d = IDData(y, u, y_names=["a", "b"], u_names="f")
    m = NARX(1, 1, 2, n_terms=3).fit(d)
    tra, trb = m.fit_recursive(d, P0=1e8)
    for tr, r in ((tra, m.results[0]), (trb, m.results[1])):
        assert tr.names == r.terms and tr.meta["output"] == r.output
        np.testing.assert_allclose(tr.theta[-1], r.theta, atol=1e-6)  # noise-free: exact
    # several experiments: the rows of each, stacked, one estimator continuing
    y1, u1 = system(N=300, seed=1)
    y2, u2 = system(N=250, seed=2)
    ms = NARX(2, 2, 2, n_terms=5).fit([IDData(y1, u1), IDData(y2, u2)])
    tr = ms.fit_recursive([IDData(y1, u1), IDData(y2, u2)])
    P1, t1 = design(ms, y1, u1)
    P2, t2 = design(ms, y2, u2)
    np.testing.assert_array_equal(tr.meta["index"], np.r_[np.arange(2, 300), np.arange(2, 250)])
    np.testing.assert_allclose(tr.theta[-1], ridge(np.vstack([P1, P2]), np.r_[t1, t2], 1e4),
                               rtol=1e-9, atol=1e-11)


# ------------------------------------------------------------------ RecursiveNARX
def test_run_is_steps_bit_for_bit_and_equals_fit_recursive(fitted):
    m, y, u = fitted
    for start in ("filled", "zero"):
        a = RecursiveNARX(m, start=start, forgetting=0.99)
        b = RecursiveNARX(m, start=start, forgetting=0.99)
        res = a.run((y, u))
        steps = [b.step(y[k], u[k]) for k in range(y.size)]
        np.testing.assert_array_equal(res.theta, np.array([s[0] for s in steps]))
        np.testing.assert_array_equal(res.yhat, np.array([s[1] for s in steps]))
        np.testing.assert_array_equal(a.estimator.P, b.estimator.P)
    assert res.names == m.terms
    filled = RecursiveNARX(m, forgetting=0.99).run(IDData(y, u))
    assert np.all(np.isnan(filled.yhat[:2])) and np.all(filled.theta[:2] == 0)
    tr = m.fit_recursive(y, u, forgetting=0.99)
    np.testing.assert_array_equal(filled.theta[2:], tr.theta)
    # (the kernel forms ε = y − φᵀθ with fused operations: equal to rounding)
    np.testing.assert_allclose(filled.yhat[2:], y[2:] - tr.error, rtol=0, atol=1e-14)
    # in pieces: the buffers carry the lags across calls
    c = RecursiveNARX(m, forgetting=0.99)
    parts = [c.run((y[:1], u[:1])), c.run((y[1:300], u[1:300])), c.run((y[300:], u[300:]))]
    np.testing.assert_array_equal(np.vstack([p.theta for p in parts]), filled.theta)


def test_state_file_round_trip_mid_stream(fitted, tmp_path):
    m, y, u = fitted
    whole = RecursiveNARX(m, forgetting=0.995).run((y, u))
    a = RecursiveNARX(m, forgetting=0.995)
    a.run((y[:250], u[:250]))
    a.save_state(tmp_path / "narx.npz")
    b = RecursiveNARX.load_state(tmp_path / "narx.npz")
    c = adaptid.load_state(tmp_path / "narx.npz")
    rest_b = b.run((y[250:], u[250:]))
    rest_c = [c.step(y[k], u[k])[0] for k in range(250, y.size)]
    np.testing.assert_array_equal(rest_b.theta, whole.theta[250:])
    np.testing.assert_array_equal(np.array(rest_c), whole.theta[250:])
    assert RecursiveNARX.from_state(a.get_state()).terms == m.terms
    with pytest.raises(adaptid.StateFileError):
        adaptid.models.RecursiveARX.load_state(tmp_path / "narx.npz")
    # damaged states are refused with the field named
    st = a.get_state()
    st["ybuf"] = st["ybuf"][:1]
    with pytest.raises(ValueError, match="state must be lag buffers"):
        RecursiveNARX.from_state(st)
    st = a.get_state()
    st["options"]["outputs"][0]["combos"][0] = [0, 99]
    with pytest.raises(ValueError, match="terms must be index tuples"):
        RecursiveNARX.from_state(st)
    st = a.get_state()
    del st["inner"]
    with pytest.raises(ValueError, match="state must be a complete dict"):
        RecursiveNARX.from_state(st)


def test_to_model_and_from_terms(fitted):
    m, y, u = fitted
    obj = RecursiveNARX(m, P0=1e8)
    obj.run((y, u))
    mm = obj.to_model()
    np.testing.assert_array_equal(mm.theta, obj.theta)
    assert mm.terms == m.terms
    np.testing.assert_allclose(mm.simulate(u, y0=y), m.simulate(u, y0=y), atol=1e-3)
    assert mm.to_equations().startswith("y(k) = ")
    assert np.all(np.isnan(mm.stderr))             # no batch statistics
    with pytest.raises(ValueError, match="model must be a batch fit"):
        mm.summary()
    t = RecursiveNARX.from_terms(list(m.terms), 2, 2, u_names=("u1", "u2"), P0=1e8)
    np.testing.assert_array_equal(t.run((y, u)).theta[-1], obj.theta)
    np.testing.assert_array_equal(t.to_model().simulate(u, y0=y), mm.simulate(u, y0=y))
    # spelling: spaces, factor order and powers are normalised
    t2 = RecursiveNARX.from_terms(["y(k-1) * u2(k-2)", "u2(k-1)^2", "1"], 2, 2,
                                  u_names=("u1", "u2"))
    assert t2.terms == ("u2(k-2)*y(k-1)", "u2(k-1)^2", "1")
    with pytest.raises(ValueError, match="terms must be '1' or products"):
        RecursiveNARX.from_terms(["y(k-3)"], 2, 2, u_names=("u1", "u2"))
    with pytest.raises(ValueError, match="output must be one of"):
        RecursiveNARX(m, output="z")


def test_mimo_streaming_one_output():
    rng = np.random.default_rng(4)
    N = 400
    u = rng.uniform(-1, 1, N)
    y = np.zeros((N, 2))
    for k in range(1, N):
        y[k, 0] = 0.5 * y[k - 1, 0] + u[k - 1] + 0.2 * y[k - 1, 1] * u[k - 1]
        y[k, 1] = 0.3 * y[k - 1, 1] - 0.4 * y[k - 1, 0] ** 2 + 0.1
    d = IDData(y, u, y_names=["a", "b"], u_names="f")
    m = NARX(1, 1, 2).fit(d)
    obj = RecursiveNARX(m, output="b", P0=1e8)
    res = obj.run(d)
    np.testing.assert_array_equal(res.theta[1:], m.fit_recursive(d, P0=1e8)[1].theta)
    th, yhat = obj.step(y[-1], u[-1])
    assert th.shape == (3,) and np.isfinite(yhat)
    with pytest.raises(ValueError, match="y must be 2 output value"):
        obj.step(1.0, 0.0)
    mm = obj.to_model()
    np.testing.assert_array_equal(mm.theta[1], obj.theta)
    np.testing.assert_allclose(mm.simulate(d), y, atol=1e-2)  # noise-free: close to the record
    np.testing.assert_array_equal(mm.theta[0], m.theta[0])  # the other output's batch θ


def naive_rels(Y, Phi_fix, q, lam, M, P0):
    """Recursive extended least squares by direct solves: at each k the regressor is
    [process terms, ε(k-1) … ε(k-q)] with ε the a-posteriori residuals so far, and θ_k
    the (forgotten, windowed) ridge solution on the rows formed (information form)."""
    N, nf = Phi_fix.shape
    n = nf + q
    eps = np.zeros(N)
    rows = np.zeros((N, n))
    Th = np.zeros((N, n))
    for k in range(N):
        rows[k] = np.r_[Phi_fix[k], [eps[k - j] if k >= j else 0.0 for j in range(1, q + 1)]]
        lo = 0 if M == 0 else max(0, k - M + 1)
        w = lam ** (k - np.arange(lo, k + 1))
        R = (rows[lo:k + 1] * w[:, None]).T @ rows[lo:k + 1] + lam ** (k + 1) * np.eye(n) / P0
        Th[k] = np.linalg.solve(R, (rows[lo:k + 1] * w[:, None]).T @ Y[lo:k + 1])
        eps[k] = Y[k] - rows[k] @ Th[k]
    return Th, rows


@pytest.mark.parametrize("lam, window", [(1.0, 0), (0.99, 0), (1.0, 80)])
def test_narmax_recursive_extended_least_squares(lam, window):
    rng = np.random.default_rng(5)
    N = 300
    u = rng.uniform(-1, 1, N)
    e = 0.05 * rng.standard_normal(N)
    y = np.zeros(N)
    for k in range(1, N):
        y[k] = 0.5 * y[k - 1] + u[k - 1] - 0.3 * u[k - 1] * y[k - 1] + e[k] + 0.6 * e[k - 1]
    m = NARX(1, 1, 2, n_terms=3, noise_lags=2).fit(y, u)
    est = (adaptid.RLS(5, forgetting=lam, P0=100.0) if window == 0
           else adaptid.SlidingWindowRLS(5, window, forgetting=lam, P0=100.0))
    tr = m.fit_recursive(y, u, est)
    k = np.arange(1, N)
    base = {"y(k-1)": y[k - 1], "u(k-1)": u[k - 1]}
    Phi = np.column_stack([np.prod([base[f] for f in t.split("*")], axis=0)
                           for t in m.terms[:3]])
    ref, rows = naive_rels(y[1:], Phi, 2, lam, window, 100.0)
    np.testing.assert_allclose(tr.theta, ref, rtol=1e-6, atol=1e-8)
    np.testing.assert_allclose(tr.meta["regressors"], rows, rtol=1e-6, atol=1e-8)
    assert tr.names == m.terms and tr.names[3:] == ("e(k-1)", "e(k-2)")
    if lam == 1.0 and window == 0:   # close to the batch extended least squares
        np.testing.assert_allclose(tr.theta[-1], m.theta, atol=0.15)


def test_run_refuses_a_merged_record_naming_it():
    from adaptid.models import IDData, NARX, RecursiveNARX
    rng = np.random.default_rng(6)
    u = rng.standard_normal(300)
    y = np.zeros(300)
    for k in range(1, 300):
        y[k] = 0.5 * y[k - 1] + u[k - 1] + 0.1 * u[k - 1] ** 2
    model = NARX(1, 1, 2).fit(IDData(y, u))
    rec = RecursiveNARX(model)
    merged = IDData(y[:150], u[:150]).merge(IDData(y[150:], u[150:]))
    with pytest.raises(ValueError, match="y must be one experiment.*merged record of 2"):
        rec.run(merged)

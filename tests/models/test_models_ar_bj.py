"""Model objects AR, ARMA and BJ of adaptid.models (issue 16, point 4).

Oracles: statsmodels ``AutoReg`` (conditional least squares, the same rows
as AR) and ``ARIMA`` (exact Gaussian likelihood, compared with ARMA's
conditional prediction-error estimate within a tolerance set by the sample
size), python-control's ``forced_response`` for ``simulate``, numpy lstsq on
windows, naive NumPy recursions written here (information-form direct
solves of the pseudo-linear regressions), naive iteration of the model for
k-step predictions, and the true parameters of simulated systems with a
Monte-Carlo spread.
"""

import control
import numpy as np
import pytest
from scipy.signal import lfilter
from statsmodels.tsa.ar_model import AutoReg
from statsmodels.tsa.arima.model import ARIMA

import adaptid
from adaptid.models import AR, ARMA, ARX, BJ, OE, NotFittedError, arx_regressors

AR_A = np.array([1.0, -1.2, 0.5])
# BJ truth: y = B/F u + C/D e
BJ_B, BJ_F = np.array([0.0, 1.0, 0.5]), np.array([1.0, -0.7])
BJ_C, BJ_D = np.array([1.0, 0.4]), np.array([1.0, -0.9])
BJ_THETA = np.r_[BJ_B[1:], BJ_C[1:], BJ_D[1:], BJ_F[1:]]   # MATLAB order [b, c, d, f]


def _bj_data(rng, N, sigma=0.3):
    u = rng.standard_normal(N)
    e = sigma * rng.standard_normal(N)
    return lfilter(BJ_B, BJ_F, u) + lfilter(BJ_C, BJ_D, e), u, e


# ------------------------------------------------------------------- AR
def test_ar_equals_statsmodels_autoreg(rng):
    N = 2000
    y = lfilter([1.0], AR_A, rng.standard_normal(N))
    ref = AutoReg(y, lags=2, trend="n").fit()
    m = AR(2).fit(y)
    # same rows (k = 2 … N-1), both by least squares: equal to rounding.
    # AutoReg's coefficients multiply y[k-j]: they are -a_j.
    np.testing.assert_allclose(m.theta, -ref.params, rtol=1e-10)
    np.testing.assert_allclose(m.residuals, ref.resid, rtol=1e-9, atol=1e-12)
    # AutoReg's sigma2 is ssr/nobs (ML), ours ssr/(nobs - d): bse scale by sqrt(nobs/(nobs-d))
    nobs = ref.nobs
    np.testing.assert_allclose(m.stderr, ref.bse * np.sqrt(nobs / (nobs - 2)), rtol=1e-8)
    assert m.names == ("a1", "a2")
    np.testing.assert_allclose(m.A, np.r_[1.0, m.theta])
    assert repr(m) == "AR(na=2, dt=1) [fitted]"


def test_ar_recursive_with_every_estimator(rng):
    N, M = 1500, 200
    y = lfilter([1.0], AR_A, rng.standard_normal(N))
    ref = AutoReg(y, lags=2, trend="n").fit()
    m = AR(2)
    traj = m.fit_recursive(y, adaptid.RLS(2, P0=1e10))
    assert traj.theta.shape == (N - 2, 2)
    # a 1e-10 ridge from the prior: 1e-7 relative is far above its effect
    np.testing.assert_allclose(m.theta, -ref.params, rtol=1e-7)
    # window: the final estimate is lstsq on the last M rows (built here)
    X = np.column_stack([-y[1:-1], -y[:-2]])
    mw = AR(2)
    mw.fit_recursive(y, adaptid.SlidingWindowRLS(2, M, P0=1e10))
    np.testing.assert_allclose(mw.theta, np.linalg.lstsq(X[-M:], y[2:][-M:], rcond=None)[0],
                               rtol=1e-6)
    mk = AR(2)
    mk.fit_recursive(y, adaptid.KalmanRLS(2, process_cov=1e-7, noise_var=1.0))
    np.testing.assert_allclose(mk.theta, AR_A[1:], atol=0.1)
    mf = AR(2)
    mf.fit_recursive(y, adaptid.RLS(2, forgetting=adaptid.forgetting.ConstantTrace(0.99, 1e-2)))
    np.testing.assert_allclose(mf.theta, AR_A[1:], atol=0.15)


def test_ar_k_step_prediction_matches_naive_iteration(rng):
    y = lfilter([1.0], AR_A, rng.standard_normal(300))
    m = AR(2).fit(y)
    a1, a2 = m.theta
    k = 3
    yz = np.r_[np.zeros(5), y]
    pred = np.empty(300)
    for t in range(300):
        T = t + 5
        yy = yz.copy()
        for s in range(T - k + 1, T + 1):   # unknown outputs replaced by predictions
            yy[s] = -a1 * yy[s - 1] - a2 * yy[s - 2]
        pred[t] = yy[T]
    np.testing.assert_allclose(m.predict(y, k=k), pred, rtol=1e-10, atol=1e-12)


# ------------------------------------------------------------------ ARMA
@pytest.mark.parametrize("a, c", [([1.0, -0.7], [1.0, 0.5]),
                                  ([1.0, -1.2, 0.5], [1.0, 0.3])])
def test_arma_close_to_statsmodels_arima(rng, a, c):
    N = 5000
    y = lfilter(c, a, rng.standard_normal(N))
    na, nc = len(a) - 1, len(c) - 1
    ref = ARIMA(y, order=(na, 0, nc), trend="n").fit()
    m = ARMA(na, nc).fit(y)
    ours = m.theta
    theirs = np.r_[-ref.params[:na], ref.params[na:na + nc]]   # ARIMA: y = Σφ y + e + Σθ e
    # ARIMA maximises the exact likelihood, we the conditional one (zero
    # initial values): the estimates differ by O(1/N) = 2e-4, against a
    # sampling spread O(1/sqrt(N)) (stderr ≈ 0.015 here): 0.1 stderr is
    # ~7 times the expected difference and far below the sampling error.
    assert np.all(np.abs(ours - theirs) <= 0.1 * m.stderr), (ours, theirs, m.stderr)
    # standard errors: both the asymptotic (ΨᵀΨ)⁻¹σ² ⇒ equal up to O(1/sqrt(N)) ≈ 1.5 %
    np.testing.assert_allclose(m.stderr, ref.bse[: na + nc], rtol=0.05)
    np.testing.assert_allclose(m.noise_variance, ref.params[-1], rtol=0.01)
    # and the truth within 4 reported standard errors
    assert np.all(np.abs(ours - np.r_[a[1:], c[1:]]) <= 4 * m.stderr)
    assert m.names == tuple([f"a{j}" for j in range(1, na + 1)] + [f"c{j}" for j in range(1, nc + 1)])


def test_arma_hannan_rissanen_start_and_refinement_lower_loss(rng):
    y = lfilter([1.0, 0.5], [1.0, -0.7], rng.standard_normal(3000))
    hr = ARMA(1, 1).fit(y, refine=False)
    pem = ARMA(1, 1).fit(y)
    assert pem.loss <= hr.loss * (1 + 1e-12)
    np.testing.assert_allclose(hr.theta, [-0.7, 0.5], atol=0.06)


def _naive_rels_arma(y, lam, M, P0):
    """ARMA(1,1) RELS by information-form direct solves: φ_k = [−y_{k-1}, ε_{k-1}],
    ε_k = y_k − φ_kᵀθ_k (a posteriori), window of M rows (0: none)."""
    Y = y[1:]
    N = Y.size
    rows, Th, eps = np.zeros((N, 2)), np.zeros((N, 2)), np.zeros(N)
    for k in range(N):
        rows[k] = [-y[k], eps[k - 1] if k else 0.0]
        lo = 0 if M == 0 else max(0, k - M + 1)
        w = lam ** (k - np.arange(lo, k + 1))
        R = (rows[lo:k + 1] * w[:, None]).T @ rows[lo:k + 1] + lam ** (k + 1) * np.eye(2) / P0
        Th[k] = np.linalg.solve(R, (rows[lo:k + 1] * w[:, None]).T @ Y[lo:k + 1])
        eps[k] = Y[k] - rows[k] @ Th[k]
    return Th


@pytest.mark.parametrize("lam, M", [(1.0, 0), (0.98, 0), (1.0, 50)])
def test_arma_recursive_matches_naive_rels(rng, lam, M):
    y = lfilter([1.0, 0.5], [1.0, -0.7], rng.standard_normal(300))
    est = adaptid.RLS(2, forgetting=lam, P0=100.0) if M == 0 else \
        adaptid.SlidingWindowRLS(2, M, P0=100.0)
    traj = ARMA(1, 1).fit_recursive(y, est)
    np.testing.assert_allclose(traj.theta, _naive_rels_arma(y, lam, M, 100.0), rtol=1e-6, atol=1e-8)


def test_ar_arma_simulate_equals_control_forced_response(rng):
    e = rng.standard_normal(400)
    for m, y in ((AR(2), lfilter([1.0], AR_A, e)), (ARMA(2, 1), lfilter([1.0, 0.3], AR_A, e))):
        m.fit(y)
        sys = m.to_control()
        assert sys.dt == 1.0
        resp = control.forced_response(sys, T=np.arange(400.0), U=e)
        np.testing.assert_allclose(m.simulate(e), resp.outputs, rtol=1e-9, atol=1e-10)
        resp_ss = control.forced_response(m.to_control("ss"), T=np.arange(400.0), U=e)
        np.testing.assert_allclose(m.simulate(e), resp_ss.outputs, rtol=1e-8, atol=1e-9)


def test_ar_arma_validation():
    with pytest.raises(ValueError, match="na must be an integer >= 1"):
        AR(0)
    with pytest.raises(ValueError, match="nc must be an integer >= 0"):
        ARMA(1, -1)
    with pytest.raises(NotFittedError):
        AR(2).predict(np.ones(10))
    with pytest.raises(ValueError, match="y must be"):
        AR(1).fit(np.ones((10, 2)))


# -------------------------------------------------------------------- BJ
def test_bj_monte_carlo_consistent_where_arx_and_oe_are_biased():
    # 50 records of N = 800 from y = B/F u + C/D e (C/D coloured noise, D ≠ F):
    # ARX(1,2,1) (equation error: noise 1/A assumed) and OE's batch fit
    # (Steiglitz-McBride, consistent for white noise only) are biased; BJ's
    # prediction-error estimate is consistent. Criterion: the Monte-Carlo mean
    # within 3 standard errors of the mean (sd / sqrt(R)) of the truth.
    R, N = 50, 800
    rng = np.random.default_rng(16)
    bj, arx, oe, se = [], [], [], []
    for _ in range(R):
        y, u, _ = _bj_data(rng, N)
        m = BJ(2, 1, 1, 1).fit(y, u)
        bj.append(m.theta)
        se.append(m.stderr)
        a = ARX(1, 2, 1).fit(y, u)
        arx.append(np.r_[a.theta[1:], a.theta[0]])          # [b0, b1, f1 = a1]
        oe.append(OE(2, 1, 1).fit(y, u, refine=False).theta)  # OE's Steiglitz-McBride fit
    bj, arx, oe = map(np.asarray, (bj, arx, oe))
    sem = bj.std(axis=0, ddof=1) / np.sqrt(R)
    assert np.all(np.abs(bj.mean(axis=0) - BJ_THETA) <= 3 * sem), (bj.mean(axis=0), sem)
    plant = BJ_THETA[[0, 1, 4]]
    for other in (arx, oe):
        z = np.abs(other.mean(axis=0) - plant) / (other.std(axis=0, ddof=1) / np.sqrt(R))
        assert z.max() > 10, z                   # measurably biased
    # the reported standard errors agree with the Monte-Carlo spread (within
    # 30 %: the sd of a sd from 50 samples is ~10 %)
    np.testing.assert_allclose(np.mean(se, axis=0), bj.std(axis=0, ddof=1), rtol=0.3)


def test_bj_batch_fit_and_polynomials(rng):
    y, u, e = _bj_data(rng, 4000)
    m = BJ(2, 1, 1, 1).fit(y, u)
    assert m.names == ("b0", "b1", "c1", "d1", "f1")
    assert np.all(np.abs(m.theta - BJ_THETA) <= 4 * m.stderr)
    np.testing.assert_allclose(m.B, np.r_[0.0, m.theta[:2]])
    np.testing.assert_allclose(m.C, np.r_[1.0, m.theta[2]])
    np.testing.assert_allclose(m.D, np.r_[1.0, m.theta[3]])
    np.testing.assert_allclose(m.F, np.r_[1.0, m.theta[4]])
    np.testing.assert_array_equal(m.A, [1.0])
    start = BJ(2, 1, 1, 1).fit(y, u, refine=False)
    assert m.loss <= start.loss * (1 + 1e-12)
    # residuals are the one-step prediction errors of the predictor formula
    # (a different code path: lfilter of D/C(y - B/F u) from row s = 2, where
    # predict starts at sample 0: equal once the start-up transients of the
    # stable filters 1/C, 1/F (poles 0.4, 0.7) have died out, 1e-9 after 200)
    np.testing.assert_allclose(m.residuals[198:], (y - m.predict(y, u))[200:], atol=1e-9)
    # the prediction error with the TRUE model is e itself (after transients)
    m.theta = BJ_THETA.copy()
    np.testing.assert_allclose((y - m.predict(y, u))[200:], e[200:], atol=1e-9)


def test_bj_k_step_prediction_matches_naive_iteration(rng):
    # write the BJ model as y = w + v, F w = B u, D v = C e; the k-step
    # predictor runs the innovations e up to t-k (computed from the data) and
    # then iterates v forward with e = 0 (Box & Jenkins' forecast function).
    y, u, _ = _bj_data(rng, 200)
    m = BJ(2, 1, 1, 1).fit(y, u)
    b0, b1, c1, d1, f1 = m.theta
    w = lfilter([0, b0, b1], [1, f1], u)
    v = y - w
    ehat = lfilter([1, d1], [1, c1], v)                  # e = D/C v
    k = 3
    pred = np.empty(200)
    for t in range(200):
        vv, ee = dict(), dict()
        for s in range(t - k + 1, t + 1):
            vp = vv.get(s - 1, v[s - 1] if s - 1 >= 0 else 0.0)
            ep = ee.get(s - 1, ehat[s - 1] if s - 1 >= 0 else 0.0)
            vv[s] = -d1 * vp + c1 * ep                      # e_s = 0 in the future
            ee[s] = 0.0
        pred[t] = w[t] + vv[t]
    np.testing.assert_allclose(m.predict(y, u, k=k), pred, rtol=1e-9, atol=1e-10)


def test_bj_simulate_equals_control_forced_response(rng):
    y, u, e = _bj_data(rng, 500)
    m = BJ(2, 1, 1, 1).fit(y, u)
    T = np.arange(500.0)
    resp = control.forced_response(m.to_control(), T=T, U=u)
    np.testing.assert_allclose(m.simulate(u), resp.outputs, rtol=1e-9, atol=1e-10)
    resp_ss = control.forced_response(m.to_control("ss"), T=T, U=u)
    np.testing.assert_allclose(m.simulate(u), resp_ss.outputs, rtol=1e-8, atol=1e-9)
    # with the noise: plus the response of C/D (a python-control tf built here)
    noise_tf = control.tf(m.C, m.D, 1.0)
    resp_e = control.forced_response(noise_tf, T=T, U=e)
    np.testing.assert_allclose(m.simulate(u, noise=e), resp.outputs + resp_e.outputs,
                               rtol=1e-9, atol=1e-10)


def _naive_bj_plr(Y, Phi_bs, nc, nd, nfs, lam, M, P0):
    """BJ pseudo-linear regression by information-form direct solves, inputs
    i = 1..m with their u-lag columns Phi_bs[i] and F orders nfs[i]:
    φ_k = [u lags…, ε_{k-1..k-nc}, −v_{k-1..k-nd}, −w⁽ⁱ⁾_{k-1..k-nf_i}…] with the
    a-posteriori w⁽ⁱ⁾_k = φ_{b_i,f_i}ᵀθ_{b_i,f_i}, v_k = y_k − Σᵢw⁽ⁱ⁾_k,
    ε_k = y_k − φ_kᵀθ_k."""
    N = Y.size
    m = len(Phi_bs)
    nbs = [P.shape[1] for P in Phi_bs]
    n = sum(nbs) + nc + nd + sum(nfs)
    w, v, eps = np.zeros((m, N)), np.zeros(N), np.zeros(N)
    rows, Th = np.zeros((N, n)), np.zeros((N, n))

    def lags(x, k, q):
        return [x[k - j] if k - j >= 0 else 0.0 for j in range(1, q + 1)]

    owner = np.r_[np.concatenate([np.full(b, i) for i, b in enumerate(nbs)]),
                  np.full(nc + nd, -1), np.concatenate([np.full(f, i) for i, f in enumerate(nfs)])]
    for k in range(N):
        rows[k] = np.r_[np.concatenate([P[k] for P in Phi_bs]), lags(eps, k, nc),
                        -np.array(lags(v, k, nd)),
                        np.concatenate([-np.array(lags(w[i], k, nfs[i])) for i in range(m)])]
        lo = 0 if M == 0 else max(0, k - M + 1)
        wt = lam ** (k - np.arange(lo, k + 1))
        R = (rows[lo:k + 1] * wt[:, None]).T @ rows[lo:k + 1] + lam ** (k + 1) * np.eye(n) / P0
        Th[k] = np.linalg.solve(R, (rows[lo:k + 1] * wt[:, None]).T @ Y[lo:k + 1])
        for i in range(m):
            w[i, k] = rows[k, owner == i] @ Th[k, owner == i]
        v[k] = Y[k] - w[:, k].sum()
        eps[k] = Y[k] - rows[k] @ Th[k]
    return Th


@pytest.mark.parametrize("lam, M", [(1.0, 0), (0.98, 0), (0.99, 80)])
def test_bj_recursive_matches_naive_plr(rng, lam, M):
    y, u, _ = _bj_data(rng, 300)
    est = adaptid.RLS(5, forgetting=lam, P0=100.0) if M == 0 else \
        adaptid.SlidingWindowRLS(5, M, forgetting=lam, P0=100.0)
    traj = BJ(2, 1, 1, 1).fit_recursive(y, u, est)
    reg = arx_regressors(y, u, 0, 2, 1)
    ref = _naive_bj_plr(reg.y, [reg.Phi], 1, 1, [1], lam, M, 100.0)
    np.testing.assert_allclose(traj.theta, ref, rtol=1e-6, atol=1e-8)
    assert traj.meta["names"] == ("b0", "b1", "c1", "d1", "f1")


def test_bj_recursive_kalman_matches_naive(rng):
    y, u, _ = _bj_data(rng, 200)
    Q, r2, P0 = 1e-4 * np.eye(4), 0.09, 10.0
    traj = BJ(2, 1, 1, 0).fit_recursive(y, u, adaptid.KalmanRLS(4, process_cov=Q, noise_var=r2,
                                                                P0=P0))
    # textbook Kalman filter for the random walk on the BJ(2,1,1,0) regressor
    reg = arx_regressors(y, u, 0, 2, 1)
    th, P, eps_p, v_p = np.zeros(4), P0 * np.eye(4), 0.0, 0.0
    for k in range(reg.y.size):
        phi = np.r_[reg.Phi[k], eps_p, -v_p]
        K = P @ phi / (r2 + phi @ P @ phi)
        th = th + K * (reg.y[k] - phi @ th)
        P = P - np.outer(K, phi @ P) + Q
        v_p = reg.y[k] - phi[:2] @ th[:2]
        eps_p = reg.y[k] - phi @ th
        np.testing.assert_allclose(traj.theta[k], th, rtol=1e-8, atol=1e-10)


@pytest.mark.parametrize("make", [
    lambda n: None,
    lambda n: adaptid.RLS(n, forgetting=0.99),
    lambda n: adaptid.RLS(n, forgetting=adaptid.forgetting.ConstantTrace(0.98, 10.0 * n)),
    lambda n: adaptid.SlidingWindowRLS(n, 100, forgetting=0.995),
    lambda n: adaptid.KalmanRLS(n, process_cov=1e-5, noise_var=0.09),
], ids=["default", "rls", "strategy", "window", "kalman"])
def test_bj_without_noise_model_is_the_oe_recursion(rng, make):
    # nc = nd = 0: the BJ regressor is OE's [u lags, -w lags] and the signal
    # w the same a-posteriori simulated output: the recursions coincide
    y, u, _ = _bj_data(rng, 600)
    t_bj = BJ(2, 0, 0, 1).fit_recursive(y, u, make(3))
    t_oe = OE(2, 1).fit_recursive(y, u, make(3))
    np.testing.assert_allclose(t_bj.theta, t_oe.theta, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(t_bj.error, t_oe.error, rtol=1e-12, atol=1e-14)
    if t_oe.forgetting is not None:
        np.testing.assert_array_equal(t_bj.forgetting, t_oe.forgetting)


def test_bj_recursive_converges_and_estimator_untouched(rng):
    y, u, _ = _bj_data(rng, 20000)
    est = adaptid.RLS(5)
    m = BJ(2, 1, 1, 1)
    traj = m.fit_recursive(y, u, est)
    assert est.n_updates == 0
    assert traj.theta.shape == (19998, 5)
    # PLR for BJ is consistent here (C/D and 1/F satisfy the SPR conditions
    # of Ljung 1999, sec. 11.3, for these low-order, well-damped polynomials);
    # 0.03 is ~3 stderr at N = 2e4 for the noise parameters
    np.testing.assert_allclose(m.theta, BJ_THETA, atol=0.03)
    refined = BJ(2, 1, 1, 1)
    refined.fit_recursive(y, u, refine=True)
    assert refined.loss <= m.loss * (1 + 1e-12)


def test_bj_validation(rng):
    with pytest.raises(ValueError, match="nb must be an integer >= 1"):
        BJ(0, 1, 1, 1)
    with pytest.raises(ValueError, match="nd must be an integer >= 0"):
        BJ(1, 1, -1, 1)
    y, u, _ = _bj_data(rng, 100)
    with pytest.raises(ValueError, match=r"nb must be an integer or a sequence of 2 integers"):
        BJ([1, 1, 1], 1, 1, 1).fit(y, np.column_stack([u, u]))
    with pytest.raises(ValueError, match="estimator must be an estimator with n_params=4"):
        BJ(1, 1, 1, 1).fit_recursive(y, u, adaptid.RLS(3))
    with pytest.raises(NotFittedError):
        BJ(1, 1, 1, 1).simulate(u)


# --------------------------------------------------------------- BJ, MISO
B2, F2 = np.array([0.0, 0.0, 0.8]), np.array([1.0, -1.2, 0.5])   # input 2: nb=1, nf=2, nk=2
MISO_THETA = np.r_[BJ_B[1:], B2[2:], BJ_C[1:], BJ_D[1:], BJ_F[1:], F2[1:]]


def _miso_data(rng, N, sigma=0.3):
    U = rng.standard_normal((N, 2))
    e = sigma * rng.standard_normal(N)
    y = lfilter(BJ_B, BJ_F, U[:, 0]) + lfilter(B2, F2, U[:, 1]) + lfilter(BJ_C, BJ_D, e)
    return y, U, e


def _miso():
    return BJ(nb=[2, 1], nc=1, nd=1, nf=[1, 2], nk=[1, 2])


def test_bj_miso_batch_and_layout(rng):
    y, U, e = _miso_data(rng, 5000)
    m = _miso().fit(y, U)
    assert m.names == ("b0_0", "b0_1", "b1_0", "c1", "d1", "f0_1", "f1_1", "f1_2")
    assert np.all(np.abs(m.theta - MISO_THETA) <= 4 * m.stderr), (m.theta, m.stderr)
    np.testing.assert_allclose(m.F, [[1.0, m.theta[5], 0.0], [1.0, *m.theta[6:]]])
    # with the true parameters the one-step prediction error is e (after transients)
    m.theta = MISO_THETA.copy()
    np.testing.assert_allclose((y - m.predict(y, U))[300:], e[300:], atol=1e-9)
    # simulate = python-control's forced response of the 1x2 system (the state-space
    # form: python-control's MIMO transfer-function simulation needs slycot)
    T = np.arange(5000.0)
    resp = control.forced_response(m.to_control("ss"), T=T, U=U.T)
    np.testing.assert_allclose(m.simulate(U), np.squeeze(resp.outputs), rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("lam, M", [(0.99, 0), (1.0, 60)])
def test_bj_miso_recursive_matches_naive_plr(rng, lam, M):
    y, U, _ = _miso_data(rng, 250)
    est = adaptid.RLS(8, forgetting=lam, P0=100.0) if M == 0 else \
        adaptid.SlidingWindowRLS(8, M, P0=100.0)
    traj = _miso().fit_recursive(y, U, est)
    reg = arx_regressors(y, U, 0, [2, 1], [1, 2])
    ref = _naive_bj_plr(reg.y, [reg.Phi[:, :2], reg.Phi[:, 2:]], 1, 1, [1, 2], lam, M, 100.0)
    np.testing.assert_allclose(traj.theta, ref, rtol=1e-6, atol=1e-8)


def test_bj_miso_without_noise_model_is_the_oe_recursion(rng):
    y, U, _ = _miso_data(rng, 500)
    est = adaptid.RLS(6, forgetting=0.995)
    t_bj = BJ([2, 1], 0, 0, [1, 2], [1, 2]).fit_recursive(y, U, est)
    t_oe = OE([2, 1], [1, 2], [1, 2]).fit_recursive(y, U, est)
    np.testing.assert_allclose(t_bj.theta, t_oe.theta, rtol=1e-12, atol=1e-14)

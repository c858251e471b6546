"""Model objects ARX, ARMAX, OE of adaptid.models.

Oracles: the true parameters of systems simulated with scipy.signal.lfilter,
a Monte-Carlo spread, statsmodels OLS (AIC), python-control responses,
numpy.linalg.lstsq, naive Python recursions written here (information-form
direct solves) and the published-procedure numbers of the DaISy dryer
(shared/data/daisy/SOURCE.md).
"""

import control
import numpy as np
import pytest
import statsmodels.api as sm
from scipy.signal import lfilter

import adaptid
from adaptid.models import ARMAX, ARX, OE, NotFittedError, arx_regressors

A_TRUE = np.array([1.0, -1.5, 0.7])
B_TRUE = np.array([0.0, 1.0, 0.5])
C_TRUE = np.array([1.0, -0.6, 0.3])   # 1/C - 1/2 strictly positive real (checked below)
F_TRUE = np.array([1.0, -1.2, 0.5])


def _spr(C, n=4096):
    w = np.linspace(0, np.pi, n)
    z = np.exp(-1j * w)
    Cw = np.polyval(C[::-1], z)
    return np.min(np.real(1.0 / Cw)) > 0.5


def _rel_err(est, true):
    return np.linalg.norm(est - true) / np.linalg.norm(true)


def _arx_data(rng, N, sigma=0.3):
    u = rng.standard_normal(N)
    e = sigma * rng.standard_normal(N)
    return lfilter(B_TRUE, A_TRUE, u) + lfilter([1.0], A_TRUE, e), u


# ------------------------------------------------------------------ ARX
def test_arx_estimates_within_3_sigma(rng):
    y, u = _arx_data(rng, 2000)
    m = ARX(2, 2, 1).fit(y, u)
    truth = np.r_[A_TRUE[1:], B_TRUE[1:]]
    assert np.all(np.abs(m.theta - truth) < 3 * m.stderr)
    assert m.names == ("a1", "a2", "b0", "b1")
    np.testing.assert_allclose(m.A, A_TRUE, atol=0.05)
    np.testing.assert_allclose(m.B, B_TRUE, atol=0.05)
    np.testing.assert_array_equal(m.C, [1.0])
    np.testing.assert_array_equal(m.F, [1.0])
    np.testing.assert_allclose(m.stderr, np.sqrt(np.diag(m.cov)))


def test_arx_sigma_matches_monte_carlo(rng):
    # 100 independent records: the spread of the estimates must agree with the
    # reported standard errors to 20 % (the sampling error of a std estimated
    # from 100 runs is about 7 %, so 20 % is ~3 of its sigmas).
    est, se = [], []
    for _ in range(100):
        y, u = _arx_data(rng, 500)
        m = ARX(2, 2, 1).fit(y, u)
        est.append(m.theta)
        se.append(m.stderr)
    spread = np.std(est, axis=0, ddof=1)
    reported = np.mean(se, axis=0)
    np.testing.assert_allclose(reported, spread, rtol=0.2)


def test_arx_equals_direct_lstsq_and_statsmodels_aic(rng):
    y, u = _arx_data(rng, 300)
    m = ARX(2, 2, 1).fit(y, u)
    # hand-built regressor (MATLAB sign convention)
    Phi = np.column_stack([-y[1:-1], -y[:-2], u[1:-1], u[:-2]])
    np.testing.assert_allclose(m.theta, np.linalg.lstsq(Phi, y[2:], rcond=None)[0], rtol=1e-10)
    ols = sm.OLS(y[2:], Phi).fit()
    np.testing.assert_allclose(m.cov, ols.cov_params(), rtol=1e-8)
    np.testing.assert_allclose(m.aic, ols.aic, rtol=1e-10)
    N, d = 298, 4
    V = np.mean(ols.resid ** 2)
    np.testing.assert_allclose(m.fpe, V * (1 + d / N) / (1 - d / N), rtol=1e-10)
    # the one-step predictor on the regression rows is Phi @ theta
    np.testing.assert_allclose(m.predict(y, u)[2:], Phi @ m.theta, rtol=1e-10, atol=1e-12)


def test_arx_several_inputs(rng):
    N = 3000
    U = rng.standard_normal((N, 2))
    y = (lfilter([0, 1.0, 0.5], A_TRUE, U[:, 0]) + lfilter([0, 0, 0, -0.8], A_TRUE, U[:, 1])
         + lfilter([1.0], A_TRUE, 0.1 * rng.standard_normal(N)))
    m = ARX(2, [2, 1], [1, 3]).fit(y, U)
    truth = np.array([-1.5, 0.7, 1.0, 0.5, -0.8])
    assert np.all(np.abs(m.theta - truth) < 4 * m.stderr)
    assert m.names == ("a1", "a2", "b0_0", "b0_1", "b1_0")
    assert m.B.shape == (2, 4)
    np.testing.assert_allclose(m.B[1], [0, 0, 0, m.theta[4]])


def test_arx_reproduces_dryer_reference():
    # DaISy 96-006, ARX [2 2 3] on samples 1..300 with the means removed;
    # reference: shared/data/daisy/SOURCE.md ("Our plain LS", first 300), 6 and 4 digits.
    d = adaptid.datasets.load_daisy("dryer")
    u, y = d.u[:300] - d.u[:300].mean(), d.y[:300] - d.y[:300].mean()
    m = ARX(2, 2, 3, dt=0.08).fit(y, u)
    np.testing.assert_allclose(m.theta, [-1.273739, 0.393546, 0.066618, 0.044482], atol=6e-7)
    np.testing.assert_allclose(m.stderr, [0.0209, 0.0191, 0.0021, 0.0033], atol=6e-5)
    np.testing.assert_allclose(m.B, [0, 0, 0, 0.066618, 0.044482], atol=6e-7)


def test_arx_recursive_with_core_estimators(rng):
    y, u = _arx_data(rng, 600)
    batch = ARX(2, 2, 1).fit(y, u)
    m = ARX(2, 2, 1)
    est = adaptid.RLS(4, P0=1e10)
    traj = m.fit_recursive(y, u, est)
    assert est.n_updates == 0           # the argument is not modified
    assert traj.theta.shape == (598, 4)
    np.testing.assert_array_equal(traj.meta["index"], np.arange(2, 600))
    np.testing.assert_allclose(m.theta, batch.theta, rtol=1e-6)
    np.testing.assert_allclose(m.cov, batch.cov, rtol=1e-4)
    # window: the final estimate is the batch LS of the last `window` rows
    reg = arx_regressors(y, u, 2, 2, 1)
    Phi = reg.Phi * np.array([-1, -1, 1, 1])
    mw = ARX(2, 2, 1)
    mw.fit_recursive(y, u, adaptid.SlidingWindowRLS(4, 100, P0=1e10))
    ref = np.linalg.lstsq(Phi[-100:], reg.y[-100:], rcond=None)[0]
    np.testing.assert_allclose(mw.theta, ref, rtol=1e-5)
    mk = ARX(2, 2, 1)
    mk.fit_recursive(y, u, adaptid.KalmanRLS(4, process_cov=1e-6, noise_var=0.09))
    assert _rel_err(mk.theta, np.r_[A_TRUE[1:], B_TRUE[1:]]) < 0.1


def test_arx_k_step_predictor_matches_naive_iteration(rng):
    y, u = _arx_data(rng, 200)
    m = ARX(2, 2, 1).fit(y, u)
    a1, a2, b0, b1 = m.theta
    k = 3
    # naive: iterate the model from time t-k, replacing unknown y by predictions
    yz = np.r_[np.zeros(10), y]
    uz = np.r_[np.zeros(10), u]
    pred = np.empty(200)
    for t in range(200):
        T = t + 10
        yy = yz.copy()
        for s in range(T - k + 1, T + 1):
            yy[s] = -a1 * yy[s - 1] - a2 * yy[s - 2] + b0 * uz[s - 1] + b1 * uz[s - 2]
        pred[t] = yy[T]
    np.testing.assert_allclose(m.predict(y, u, k=k), pred, rtol=1e-10, atol=1e-12)
    np.testing.assert_array_equal(m.predict(y, u, k=1), m.predict(y, u))


# ---------------------------------------------------------------- ARMAX
@pytest.fixture(scope="module")
def armax_data():
    rng = np.random.default_rng(7)
    N = 20000
    u = rng.standard_normal(N)
    e = 0.5 * rng.standard_normal(N)
    y = lfilter(B_TRUE, A_TRUE, u) + lfilter(C_TRUE, A_TRUE, e)
    return y, u, np.r_[A_TRUE[1:], B_TRUE[1:], C_TRUE[1:]]


def test_armax_coloured_noise_arx_biased_rels_consistent(armax_data):
    y, u, truth = armax_data
    assert _spr(C_TRUE)
    arx = ARX(2, 2, 1).fit(y, u)
    # ARX is biased: far more than its own standard errors, and > 3 % off
    assert _rel_err(arx.theta, truth[:4]) > 0.03
    assert np.max(np.abs(arx.theta - truth[:4]) / arx.stderr) > 10
    m = ARMAX(2, 2, 2, 1)
    traj = m.fit_recursive(y, u)
    assert _rel_err(m.theta, truth) < 0.02
    assert traj.theta.shape == (N_ROWS := 19998, 6) and traj.error.shape == (N_ROWS,)
    assert m.names == ("a1", "a2", "b0", "b1", "c1", "c2")
    np.testing.assert_allclose(m.C, [1.0, *m.theta[4:]])


def test_armax_batch_and_refined_consistent(armax_data):
    y, u, truth = armax_data
    m = ARMAX(2, 2, 2, 1).fit(y, u, refine=False)   # the Hannan-Rissanen estimate alone
    assert _rel_err(m.theta, truth) < 0.02
    r = ARMAX(2, 2, 2, 1).fit(y, u, refine=True)
    assert _rel_err(r.theta, truth) < 0.02
    assert r.loss <= m.loss * (1 + 1e-12)
    # prediction-error covariance: the truth within 4 reported sigmas
    assert np.all(np.abs(r.theta - truth) < 4 * r.stderr)
    # the residuals are the model's own one-step prediction errors on its rows
    np.testing.assert_allclose(r.residuals[-1000:], (y - r.predict(y, u))[-1000:], atol=1e-8)


def _naive_rels(Y, Phi_fix, nc, lam, M, P0):
    """Information-form direct solve of the windowed, forgotten ARMAX RELS."""
    N, nf = Phi_fix.shape
    n = nf + nc
    eps = np.zeros(N)
    rows = np.zeros((N, n))
    Th = np.zeros((N, n))
    for k in range(N):
        lags = [eps[k - j] if k - j >= 0 else 0.0 for j in range(1, nc + 1)]
        rows[k] = np.r_[Phi_fix[k], lags]
        lo = 0 if M == 0 else max(0, k - M + 1)
        w = lam ** (k - np.arange(lo, k + 1))
        R = (rows[lo:k + 1] * w[:, None]).T @ rows[lo:k + 1] + lam ** (k + 1) * np.eye(n) / P0
        r = (rows[lo:k + 1] * w[:, None]).T @ Y[lo:k + 1]
        Th[k] = np.linalg.solve(R, r)
        eps[k] = Y[k] - rows[k] @ Th[k]
    return Th


@pytest.mark.parametrize("lam, window", [(1.0, 0), (0.98, 0), (1.0, 60), (0.99, 60)])
def test_rels_kernel_matches_direct_solve(rng, lam, window):
    y, u = _arx_data(rng, 250)
    y = y + lfilter([0, 0.5], [1.0], 0.3 * rng.standard_normal(250))
    reg = arx_regressors(y, u, 2, 2, 1)
    Phi_fix = reg.Phi * np.array([-1, -1, 1, 1])
    est = (adaptid.RLS(5, forgetting=lam, P0=100.0) if window == 0
           else adaptid.SlidingWindowRLS(5, window, forgetting=lam, P0=100.0))
    traj = ARMAX(2, 2, 1).fit_recursive(y, u, est)
    ref = _naive_rels(reg.y, Phi_fix, 1, lam, window, 100.0)
    np.testing.assert_allclose(traj.theta, ref, rtol=1e-6, atol=1e-8)


def test_armax_without_c_equals_core_rls(rng):
    # nc = 0: the compiled RELS is plain RLS; compare with the core's U-D RLS
    y, u = _arx_data(rng, 400)
    t1 = ARMAX(2, 2, 0).fit_recursive(y, u, adaptid.RLS(4, forgetting=0.99))
    t2 = ARX(2, 2, 1).fit_recursive(y, u, adaptid.RLS(4, forgetting=0.99))
    np.testing.assert_allclose(t1.theta, t2.theta, rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(t1.error, t2.error, rtol=1e-8, atol=1e-10)


def test_rels_with_kalman_matches_naive(rng):
    y, u = _arx_data(rng, 150)
    Q = 1e-4 * np.eye(5)
    est = adaptid.KalmanRLS(5, process_cov=Q, noise_var=0.5, P0=10.0)
    traj = ARMAX(2, 2, 1).fit_recursive(y, u, est)
    reg = arx_regressors(y, u, 2, 2, 1)
    Phi_fix = reg.Phi * np.array([-1, -1, 1, 1])
    th, P, eps_prev = np.zeros(5), 10.0 * np.eye(5), 0.0
    for k in range(len(reg.y)):
        phi = np.r_[Phi_fix[k], eps_prev]
        K = P @ phi / (0.5 + phi @ P @ phi)
        th = th + K * (reg.y[k] - phi @ th)
        P = P - np.outer(K, phi @ P) + Q
        eps_prev = reg.y[k] - phi @ th
        np.testing.assert_allclose(traj.theta[k], th, rtol=1e-9, atol=1e-12)


# ------------------------------------------------------------------- OE
@pytest.fixture(scope="module")
def oe_data():
    rng = np.random.default_rng(11)
    N = 20000
    u = rng.standard_normal(N)
    y = lfilter(B_TRUE, F_TRUE, u) + 0.5 * rng.standard_normal(N)
    return y, u, np.r_[B_TRUE[1:], F_TRUE[1:]]


def test_oe_consistent_where_arx_biased(oe_data):
    y, u, truth = oe_data
    arx = ARX(2, 2, 1).fit(y, u)
    arx_as_oe = np.r_[arx.theta[2:], arx.theta[:2]]
    assert _rel_err(arx_as_oe, truth) > 0.1
    m = OE(2, 2, 1)
    traj = m.fit_recursive(y, u)
    assert _rel_err(m.theta, truth) < 0.02
    assert traj.theta.shape[1] == 4
    assert m.names == ("b0", "b1", "f1", "f2")
    b = OE(2, 2, 1).fit(y, u, refine=False)   # Steiglitz-McBride alone
    assert _rel_err(b.theta, truth) < 0.02
    r = OE(2, 2, 1).fit(y, u, refine=True)
    assert _rel_err(r.theta, truth) < 0.02
    assert np.all(np.abs(r.theta - truth) < 4 * r.stderr)
    np.testing.assert_allclose(r.F, F_TRUE, atol=0.02)
    np.testing.assert_allclose(r.A, [1.0])


def test_oe_prediction_is_simulation(oe_data):
    y, u, _ = oe_data
    m = OE(2, 2, 1).fit(y[:2000], u[:2000])
    sim = m.simulate(u[:500])
    np.testing.assert_allclose(m.predict(y[:500], u[:500]), sim, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(m.predict(y[:500], u[:500], k=4), sim, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(sim, lfilter(m.B, m.F, u[:500]), rtol=1e-12)


# ----------------------------------------------------------- to_control
@pytest.mark.parametrize("form", ["tf", "ss"])
def test_to_control_step_and_forced_response_equal_simulate(rng, armax_data, form):
    y, u, _ = armax_data
    dt = 0.05
    models = [ARX(2, 2, 1, dt=dt).fit(y[:3000], u[:3000]),
              ARMAX(2, 2, 2, 1, dt=dt).fit(y[:3000], u[:3000]),
              OE(2, 2, 2, dt=dt).fit(y[:3000], u[:3000])]
    N = 200
    T = np.arange(N) * dt
    uu = rng.standard_normal(N)
    for m in models:
        sys = m.to_control(form)
        assert sys.dt == dt
        step = control.step_response(sys, T)
        np.testing.assert_allclose(np.squeeze(step.outputs), m.simulate(np.ones(N)),
                                   rtol=1e-9, atol=1e-10)
        forced = control.forced_response(sys, T, uu)
        np.testing.assert_allclose(np.squeeze(forced.outputs), m.simulate(uu),
                                   rtol=1e-9, atol=1e-10)
    # the transfer function's polynomials are the model's
    tf = models[1].to_control("tf")
    np.testing.assert_allclose(np.trim_zeros(tf.num[0][0], "f"), models[1].B[1:], rtol=1e-12)
    np.testing.assert_allclose(tf.den[0][0], models[1].A, rtol=1e-12)


def test_to_control_several_inputs(rng):
    N = 1000
    U = rng.standard_normal((N, 2))
    y = lfilter([0, 1.0, 0.5], A_TRUE, U[:, 0]) + lfilter([0, 0, 0.3], A_TRUE, U[:, 1])
    m = ARX(2, [2, 1], [1, 2], dt=0.1).fit(y + 0.01 * rng.standard_normal(N), U)
    T = np.arange(300) * 0.1
    ss = m.to_control("ss")
    r = control.forced_response(ss, T, U[:300].T)
    np.testing.assert_allclose(np.squeeze(r.outputs), m.simulate(U[:300]), rtol=1e-9, atol=1e-10)
    tf = m.to_control("tf")
    assert tf.ninputs == 2 and tf.noutputs == 1
    r1 = control.forced_response(tf[0, 1], T, U[:300, 1])
    np.testing.assert_allclose(np.squeeze(r1.outputs), m.simulate(np.c_[0 * U[:300, 0], U[:300, 1]]),
                               rtol=1e-9, atol=1e-10)


def test_simulate_with_noise_reproduces_the_data(rng):
    N = 300
    u, e = rng.standard_normal(N), 0.2 * rng.standard_normal(N)
    y = lfilter(B_TRUE, A_TRUE, u) + lfilter(C_TRUE, A_TRUE, e)
    m = ARMAX(2, 2, 2, 1).fit(y, u)
    m.theta = np.r_[A_TRUE[1:], B_TRUE[1:], C_TRUE[1:]]
    np.testing.assert_allclose(m.simulate(u, noise=e), y, rtol=1e-10, atol=1e-12)
    # with the true model the one-step prediction errors are the innovations
    np.testing.assert_allclose(y - m.predict(y, u), e, rtol=1e-8, atol=1e-10)
    assert m.fit_percent(y, u, k=1) > m.fit_percent(y, u)


def test_fit_percent_uses_nrmse(rng):
    y, u = _arx_data(rng, 500, sigma=0.0)
    m = ARX(2, 2, 1).fit(y, u)
    assert m.fit_percent(y, u) == pytest.approx(100.0, abs=1e-6)
    y2 = y + 0.5 * rng.standard_normal(500)
    expected = 100 * (1 - np.linalg.norm(y2 - m.simulate(u)) / np.linalg.norm(y2 - y2.mean()))
    assert m.fit_percent(y2, u) == pytest.approx(expected, rel=1e-12)


# ----------------------------------------------------------- bad input
def test_bad_orders_and_short_records(rng):
    y, u = rng.standard_normal(50), rng.standard_normal(50)
    with pytest.raises(ValueError, match="na must be an integer >= 0"):
        ARX(-1, 2, 1)
    with pytest.raises(ValueError, match="nc must be an integer >= 0"):
        ARMAX(1, 1, -2, 1)
    with pytest.raises(ValueError, match="nf must be an integer >= 0"):
        OE(1, -1, 1)
    with pytest.raises(ValueError, match="nb must be an integer >= 1"):
        OE(0, 1, 1)
    with pytest.raises(ValueError, match="nk must be an integer >= 0"):
        ARX(1, 1, -1)
    with pytest.raises(ValueError, match="dt must be in"):
        ARX(1, 1, 1, dt=0.0)
    with pytest.raises(ValueError, match="y must be longer than 6 samples"):
        ARX(2, 3, 4).fit(y[:6], u[:6])
    with pytest.raises(ValueError, match="y must be longer than 4 samples"):
        ARMAX(4, 1, 1).fit_recursive(y[:4], u[:4])
    with pytest.raises(ValueError, match="nf must be an integer or a sequence of 2"):
        OE(1, [1, 1, 1]).fit(y, np.c_[u, u])
    with pytest.raises(ValueError, match=r"nb\[1\] must be an integer >= 1"):
        OE([1, 0], 1)
    with pytest.raises(ValueError, match="nb must be an integer or a sequence of 2"):
        ARX(1, [1, 1, 1], 1).fit(y, np.c_[u, u])
    m = ARX(1, 1, 1)
    with pytest.raises(NotFittedError):
        m.predict(y, u)
    with pytest.raises(ValueError, match="form must be one of"):
        ARX(1, 1).fit(y, u).to_control("zpk")
    with pytest.raises(ValueError, match="k must be an integer >= 1"):
        ARX(1, 1).fit(y, u).predict(y, u, k=0)
    with pytest.raises(ValueError, match="estimator must be an estimator with n_params=2"):
        ARMAX(1, 1, 0).fit_recursive(y, u, adaptid.RLS(3))
    with pytest.raises(ValueError, match="u must be with 1 input"):
        ARX(1, 1).fit(y, u).simulate(np.c_[u, u])


def test_public_index():
    import adaptid.models as models

    expected = {"Regression", "arx_regressors", "fir_regressors", "trend_regressors",
                "exponential_regressors", "table_regressors", "dc_motor_regressors",
                "DCMotorRegressors", "ARX", "ARMAX", "OE", "AR", "ARMA", "BJ", "NotFittedError",
                # issue 15: the identification workflow
                "IDData", "compare", "resid", "select_order", "CompareResult", "ResidResult",
                "OrderSelection", "model_summary", "recursive_summary",
                # issue 34: state-space models
                "StateSpaceModel", "n4sid", "era", "okid",
                # issue 35: nonlinear models
                "NARX", "stlsq", "SINDy",
                # issue 37: regularised and instrumental-variable estimation
                "impulseest", "arx_regul", "kernel_matrix", "iv4", "ivx",
                # issue 36: frequency responses
                "FrequencyResponse", "spa", "etfe",
                # issue 36: step responses, roots, transfer-function estimation
                "tfest", "TransferFunctionModel", "StepResponse", "Roots",
                # issue 33: streaming model objects
                "RecursiveARX", "RecursiveAR", "StreamResult",
                # issue 37: recursive instrumental variables
                "RecursiveIV", "RecursiveIVResult",
                # issue 37: closed-loop identification
                "checkfeedback", "FeedbackResult", "indirect", "two_stage",
                # issue 34: MIMO ARX
                "MIMOARX",
                # issue 35: streaming NARX
                "RecursiveNARX",
                # issue 36: frequency-dependent resolution spectral analysis, compare
                "spafdr", "FrequencyCompareResult",
                # issue 33: streaming pseudo-linear model objects
                "RecursiveARMAX", "RecursiveARMA", "RecursiveOE", "RecursiveBJ"}
    assert set(models.__all__) == expected
    with pytest.raises(AttributeError):
        models.no_such_name  # noqa: B018


def test_example_runs(tmp_path):
    import subprocess
    import sys
    from pathlib import Path

    script = Path(__file__).resolve().parents[2] / "examples" / "arx_models.py"
    out = subprocess.run([sys.executable, str(script), "--no-plot", "-n", "4000"],
                         capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert out.returncode == 0, out.stderr
    assert "python-control step response vs simulate" in out.stdout


@pytest.mark.parametrize("model", ["armax", "oe"])
def test_pseudolinear_recursion_keeps_a_diffuse_prior_accurate(rng, model):
    """With nc = 0 (ARMAX) or nf = 0 (OE) the pseudo-linear recursion is plain
    RLS on fixed regressors. From a diffuse prior (P0 = 1e12, λ = 1) every
    estimate from sample n + 1 on must equal ordinary least squares on the
    rows so far (numpy.linalg.lstsq), as the core RLS does: the plain
    covariance form misses this by orders of magnitude."""
    y, u = _arx_data(rng, 300)
    if model == "armax":
        m, reg = ARMAX(2, 2, 0), arx_regressors(y, u, 2, 2, 1)
    else:
        m, reg = OE(3, 0, 1), arx_regressors(y, u, 0, 3, 1)
    n = reg.Phi.shape[1]
    traj = m.fit_recursive(y, u, adaptid.RLS(n, P0=1e12))
    Phi = reg.Phi * (np.array([-1, -1, 1, 1]) if model == "armax" else 1.0)
    worst = 0.0
    for k in range(n + 1, len(reg.y) + 1):
        ols = np.linalg.lstsq(Phi[:k], reg.y[:k], rcond=None)[0]
        worst = max(worst, np.max(np.abs(traj.theta[k - 1] - ols)) / np.max(np.abs(ols)))
    assert worst < 1e-6


@pytest.mark.parametrize("make", [
    lambda n: adaptid.RLS(n, forgetting=adaptid.forgetting.Directional(0.97), P0=100.0),
    lambda n: adaptid.RLS(n, forgetting=adaptid.forgetting.ConstantTrace(0.95, 50.0, 0.01)),
    lambda n: adaptid.RLS(n, forgetting=adaptid.forgetting.EFRA(0.5, 0.005, 0.005, 0.95), P0=1.0),
    lambda n: adaptid.RLS(n, forgetting=adaptid.forgetting.Variable(0.9, 0.1, 200.0)),
    lambda n: adaptid.RLS(n, forgetting=0.97, P_max=50.0),
], ids=["directional", "constant_trace", "efra", "variable", "p_max"])
@pytest.mark.parametrize("model", ["armax", "oe"])
def test_pseudolinear_recursion_takes_forgetting_strategies(rng, make, model):
    """Without dynamic columns (nc = 0, nf = 0) the recursion with a strategy
    is the core RLS with that strategy on the fixed regressors (whose step is
    checked against the textbook recursions in test_forgetting.py)."""
    y, u = _arx_data(rng, 400)
    if model == "armax":
        m, reg, sign = ARMAX(2, 2, 0), arx_regressors(y, u, 2, 2, 1), np.array([-1, -1, 1, 1])
    else:
        m, reg, sign = OE(3, 0, 1), arx_regressors(y, u, 0, 3, 1), 1.0
    n = reg.Phi.shape[1]
    traj = m.fit_recursive(y, u, make(n))
    core = make(n)
    ref = core.run(reg.Phi * sign, reg.y)
    np.testing.assert_allclose(traj.theta, ref.theta, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(traj.error, ref.error, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(traj.forgetting, ref.forgetting, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(m.P, core.P, rtol=1e-8, atol=1e-12)


def test_armax_with_a_strategy_tracks_a_jump(rng):
    """RELS with directional forgetting follows a change of the plant."""
    N = 6000
    u = rng.standard_normal(N)
    e = 0.1 * rng.standard_normal(N)
    y = np.r_[lfilter([0, 1.0, 0.5], [1, -1.5, 0.7], u[:3000]) + lfilter([1, 0.5], [1, -1.5, 0.7], e[:3000]),
              lfilter([0, 2.0, 0.5], [1, -1.5, 0.7], u[3000:]) + lfilter([1, 0.5], [1, -1.5, 0.7], e[3000:])]
    m = ARMAX(2, 2, 1, 1)
    traj = m.fit_recursive(y, u, adaptid.RLS(5, forgetting=adaptid.forgetting.Directional(0.99)))
    assert abs(traj.theta[-1, 2] - 2.0) < 0.1       # b0 after the change
    assert abs(traj.theta[2500, 2] - 1.0) < 0.1     # b0 before it
    assert traj.forgetting.shape == (traj.theta.shape[0],)

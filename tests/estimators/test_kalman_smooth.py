"""Smoothed tracks, likelihood and variance MLE of ``KalmanRLS`` (issue 37, point 4).

Oracles (none of them adaptid code):

* statsmodels' state-space model of the same time-varying regression
  (``MLEModel`` with design Z_t = φ_tᵀ, transition I, selection I, state_cov
  R₁, obs_cov R₂; ``initialization="known"`` with θ₀, P₀ or ``"diffuse"``):
  its smoother (``smoothed_state``, ``smoothed_state_cov``), filter
  (``filtered_state``, ``filtered_state_cov``), ``llf`` and its ``fit``
  (BFGS on the same parameters, ``cov_type="approx"``: the complex-step
  Hessian of the log-likelihood in the variances);
* the classical Rauch–Tung–Striebel smoother written out below in NumPy
  (the gain J_k = P_{k|k} P_{k+1|k}⁻¹ by ``np.linalg.solve``), with a full
  R₁ and per-sample weights;
* the dense Gaussian log-likelihood of y (its covariance Φ-structured,
  factorised by ``scipy.linalg.cho_factor``).
"""

import warnings

import numpy as np
import pytest
import scipy.linalg as sla

from adaptid import KalmanRLS

from statsmodels.tsa.statespace.mlemodel import MLEModel  # noqa: E402 - test extra

N, n = 150, 3
THETA0 = np.array([0.5, -0.2, 0.1])
P0 = np.array([[2.0, 0.3, 0.0], [0.3, 1.0, 0.1], [0.0, 0.1, 0.5]])
Q, R = 0.0025, 0.09


@pytest.fixture
def data(rng):
    Phi = rng.standard_normal((N, n))
    theta = 1.0 + np.cumsum(0.05 * rng.standard_normal((N, n)), axis=0)
    y = np.einsum("ki,ki->k", Phi, theta) + 0.3 * rng.standard_normal(N)
    return Phi, y, theta


class _TV(MLEModel):
    """statsmodels' time-varying regression θ_{k+1} = θ_k + ν, y_k = φ_kᵀθ_k + e_k;
    params (q, r) or (q_1..q_n, r), positive through squares."""

    def __init__(self, Phi, y, *, diffuse, per=False, theta0=THETA0, P0=P0):
        kw = ({"initialization": "diffuse"} if diffuse else
              {"initialization": "known", "initial_state": theta0, "initial_state_cov": P0})
        k = Phi.shape[1]
        super().__init__(y, k_states=k, k_posdef=k, **kw)
        self["design"] = Phi.T[None]
        self["transition"] = np.eye(k)
        self["selection"] = np.eye(k)
        self.per, self.k = per, k

    @property
    def start_params(self):
        return np.r_[[0.01] * (self.k if self.per else 1), 0.1]

    @property
    def param_names(self):
        return [f"q{i}" for i in range(self.k if self.per else 1)] + ["r"]

    def transform_params(self, unconstrained):
        return unconstrained ** 2

    def untransform_params(self, constrained):
        return constrained ** 0.5

    def update(self, params, **kwargs):
        params = super().update(params, **kwargs)
        q = params[:-1]
        self["state_cov"] = np.diag(q) if self.per else q[0] * np.eye(self.k)
        self["obs_cov"] = np.array([[params[-1]]])


def _sm_smooth(Phi, y, diffuse, q=Q, r=R, Qmat=None):
    m = _TV(Phi, y, diffuse=diffuse)
    if Qmat is not None:
        m["state_cov"] = Qmat
        m["obs_cov"] = np.array([[r]])
        return m.ssm.smooth()
    return m.smooth([q, r])


def _est(diffuse, **kw):
    if diffuse:
        return KalmanRLS(n, process_cov=kw.pop("q", Q), noise_var=kw.pop("r", R), P0="diffuse",
                         **kw)
    return KalmanRLS(n, process_cov=kw.pop("q", Q), noise_var=kw.pop("r", R), theta0=THETA0,
                     P0=P0, **kw)


def _cov(x):  # statsmodels' (n, n, N) -> (N, n, n)
    return np.moveaxis(x, -1, 0)


# --------------------------------------------------------------- the smoother
@pytest.mark.parametrize("diffuse", [False, True])
def test_smooth_equals_statsmodels(data, diffuse):
    Phi, y, _ = data
    res = _est(diffuse).smooth(Phi, y)
    sm = _sm_smooth(Phi, y, diffuse)
    # the same recursions in another order: agreement to rounding, 1e-8 is loose
    np.testing.assert_allclose(res.theta, sm.smoothed_state.T, rtol=0, atol=1e-8)
    np.testing.assert_allclose(res.P, _cov(sm.smoothed_state_cov), rtol=0, atol=1e-8)
    np.testing.assert_allclose(res.theta_filtered, sm.filtered_state.T, rtol=0, atol=1e-8)
    np.testing.assert_allclose(res.P_filtered, _cov(sm.filtered_state_cov), rtol=0, atol=1e-8)
    np.testing.assert_allclose(res.error, sm.forecasts_error[0], rtol=0, atol=1e-8)
    assert res.loglike == pytest.approx(sm.llf, abs=1e-8)
    if diffuse:
        # identified after sample k (0-based) = the diffuse phase covers samples 0..k
        assert sm.nobs_diffuse == np.argmax(res.identified) + 1 == n


def _rts_numpy(Phi, y, theta0, P0, Qm, r, w):
    """Textbook filter + classical RTS (Särkkä 2013, Alg. 8.2) in NumPy."""
    Nn, k = Phi.shape
    a, P = theta0.copy(), P0.copy()
    af, Pf, Pp = np.empty((Nn, k)), np.empty((Nn, k, k)), np.empty((Nn, k, k))
    for t in range(Nn):
        phi = Phi[t]
        if w[t] > 0:
            S = phi @ P @ phi + r / w[t]
            K = P @ phi / S
            a = a + K * (y[t] - phi @ a)
            P = P - np.outer(K, phi @ P)
        af[t], Pf[t] = a, P
        P = P + Qm
        Pp[t] = P  # P_{t+1|t}
    As, Ps = af.copy(), Pf.copy()
    for t in range(Nn - 2, -1, -1):
        J = np.linalg.solve(Pp[t], Pf[t]).T  # P_{t|t} P_{t+1|t}^{-1} (both symmetric)
        As[t] = af[t] + J @ (As[t + 1] - af[t])
        Ps[t] = Pf[t] + J @ (Ps[t + 1] - Pp[t]) @ J.T
    return As, Ps


def test_smooth_equals_classical_rts(data, rng):
    Phi, y, _ = data
    A = rng.standard_normal((n, n))
    Qm = 0.002 * (A @ A.T) / n + 1e-4 * np.eye(n)  # a full R1
    w = rng.uniform(0.5, 2.0, N)
    w[[10, 77]] = 0.0  # missing samples: time update only
    res = KalmanRLS(n, process_cov=Qm, noise_var=R, theta0=THETA0, P0=P0).smooth(Phi, y, weights=w)
    As, Ps = _rts_numpy(Phi, y, THETA0, P0, Qm, R, w)
    np.testing.assert_allclose(res.theta, As, rtol=0, atol=1e-9)
    np.testing.assert_allclose(res.P, Ps, rtol=0, atol=1e-9)
    assert np.isnan(res.error[[10, 77]]).all()


@pytest.mark.parametrize("diffuse", [False, True])
def test_missing_samples_as_statsmodels(data, diffuse):
    Phi, y, _ = data
    y = y.copy()
    y[[5, 40, 41, 120]] = np.nan  # statsmodels: missing observations
    res = _est(diffuse, nan_policy="skip").smooth(Phi, y)
    sm = _sm_smooth(Phi, y, diffuse)
    np.testing.assert_allclose(res.theta, sm.smoothed_state.T, rtol=0, atol=1e-8)
    np.testing.assert_allclose(res.P, _cov(sm.smoothed_state_cov), rtol=0, atol=1e-8)
    assert res.loglike == pytest.approx(sm.llf, abs=1e-8)
    with pytest.raises(ValueError, match="y"):
        _est(diffuse).smooth(Phi, y)  # nan_policy="raise"


@pytest.mark.parametrize("diffuse", [False, True])
def test_filtered_track_is_runs_and_state_untouched(data, diffuse):
    Phi, y, _ = data
    est = _est(diffuse)
    est.run(Phi[:20], y[:20])
    before = est.get_state()
    res = est.smooth(Phi, y)
    after = est.get_state()
    np.testing.assert_array_equal(before["state"], after["state"])
    assert est.n_updates == 20
    # from the prior, not from the current state: a fresh estimator's run
    traj = _est(diffuse).run(Phi, y)
    np.testing.assert_allclose(res.theta_filtered, traj.theta, rtol=0, atol=1e-10)
    if diffuse:
        np.testing.assert_array_equal(res.identified, traj.identified)
    # the last smoothed estimate is the last filtered one
    np.testing.assert_allclose(res.theta[-1], res.theta_filtered[-1], rtol=0, atol=1e-12)


def test_diffuse_never_identified_has_infinite_covariance(data):
    Phi, y, _ = data
    res = _est(True).smooth(Phi[:2], y[:2])  # 2 samples, 3 parameters
    assert not res.identified.any()
    assert np.isinf(res.P).all()
    assert np.isinf(res.stderr_filtered).all()


def test_vague_finite_prior_warns_and_diffuse_does_not(data):
    from adaptid import DefinitenessLossWarning
    Phi, y, _ = data
    with pytest.warns(DefinitenessLossWarning, match="diffuse"):
        KalmanRLS(n, process_cov=Q, noise_var=R, P0=1e10).smooth(Phi, y)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        res = _est(True).smooth(Phi, y)
    assert np.all(np.diagonal(res.P, axis1=1, axis2=2) > 0)


# ------------------------------------------------------------- the likelihood
def _dense_llf(Phi, y, theta0, P0, q, r):
    """log N(y; Φθ₀, Σ): θ_k = θ_1 + Σ_{j<k} ν_j, so Cov(θ_i, θ_j) = P0 + min(i, j)·q·I
    (0-based i, j)."""
    idx = np.arange(len(y))
    C = np.minimum.outer(idx, idx)
    Sigma = (Phi @ P0 @ Phi.T) + q * C * (Phi @ Phi.T) + r * np.eye(len(y))
    c, low = sla.cho_factor(Sigma)
    v = y - Phi @ theta0
    return -0.5 * (len(y) * np.log(2 * np.pi) + 2 * np.log(np.diag(c)).sum()
                   + v @ sla.cho_solve((c, low), v))


def test_loglike_known_prior_equals_dense_gaussian(data):
    Phi, y, _ = data
    est = _est(False)
    assert est.loglike(Phi, y) == pytest.approx(_dense_llf(Phi, y, THETA0, P0, Q, R), abs=1e-8)
    assert est.n_updates == 0


@pytest.mark.parametrize("diffuse", [False, True])
def test_loglike_equals_statsmodels(data, diffuse):
    Phi, y, _ = data
    for q, r in [(Q, R), (1e-5, 0.5), (0.1, 0.01)]:
        sm = _TV(Phi, y, diffuse=diffuse).loglike([q, r])
        assert _est(diffuse, q=q, r=r).loglike(Phi, y) == pytest.approx(sm, abs=1e-8)


# ---------------------------------------------------------- the variance MLE
@pytest.mark.parametrize("diffuse", [False, True])
@pytest.mark.parametrize("per", [False, True])
def test_fit_variances_equals_statsmodels(rng, diffuse, per):
    Phi = rng.standard_normal((400, 2))
    theta = 1.0 + np.cumsum(0.05 * rng.standard_normal((400, 2)), axis=0)
    y = np.einsum("ki,ki->k", Phi, theta) + 0.3 * rng.standard_normal(400)
    kw = {"P0": "diffuse"} if diffuse else {"theta0": [0.5, -0.2], "P0": 2.0}
    est = KalmanRLS(2, process_cov=0.01, noise_var=0.1, **kw)
    fit = est.fit_variances(Phi, y, per_parameter=per)
    mod = _TV(Phi, y, diffuse=diffuse, per=per, theta0=np.array([0.5, -0.2]), P0=2.0 * np.eye(2))
    with warnings.catch_warnings():  # statsmodels' optimiser's own warnings: not under test
        warnings.simplefilter("ignore")
        smfit = mod.fit(disp=False, method="bfgs", maxiter=1000, gtol=1e-8, cov_type="approx")
    assert fit.converged
    # both at the same maximum: statsmodels' BFGS stops at gtol 1e-8, ours after Newton
    # steps; 1e-5 relative is the optimisers' agreement, not a property of the model
    np.testing.assert_allclose(fit.params, smfit.params, rtol=1e-5)
    assert fit.loglike >= smfit.llf - 1e-8
    # complex-step (statsmodels) vs central-difference (ours) Hessians: 1e-3 relative
    np.testing.assert_allclose(fit.stderr, smfit.bse, rtol=1e-3)
    assert fit.estimator().loglike(Phi, y) == pytest.approx(fit.loglike, abs=1e-10)
    assert est.n_updates == 0


def test_fit_variances_recovers_the_drift(rng):
    # one long record: the estimates within 3 standard errors of the truth
    Nl, q, r = 3000, 4e-4, 0.04
    Phi = np.column_stack([np.ones(Nl), rng.standard_normal(Nl)])
    theta = np.cumsum(np.sqrt(q) * rng.standard_normal((Nl, 2)), axis=0)
    y = np.einsum("ki,ki->k", Phi, theta) + np.sqrt(r) * rng.standard_normal(Nl)
    fit = KalmanRLS(2, process_cov=1e-2, noise_var=1.0, P0="diffuse").fit_variances(Phi, y)
    assert abs(fit.process_var - q) < 3 * fit.stderr[0]
    assert abs(fit.noise_var - r) < 3 * fit.stderr[1]
    est = fit.estimator()
    assert est.diffuse and est.noise_var == fit.noise_var
    np.testing.assert_allclose(est.process_cov, fit.process_var * np.eye(2))


def test_a_variance_on_its_bound_has_no_standard_error(rng):
    # the first parameter is constant: its variance goes to zero, where the
    # information in log q vanishes; the others keep theirs
    from adaptid import AdaptidWarning
    Nl = 1500
    Phi = np.column_stack([np.ones(Nl), rng.standard_normal(Nl)])
    theta = np.column_stack([np.full(Nl, 0.5),
                             2.0 + np.cumsum(0.01 * rng.standard_normal(Nl))])
    y = np.einsum("ki,ki->k", Phi, theta) + 0.2 * rng.standard_normal(Nl)
    est = KalmanRLS(2, process_cov=1e-2, noise_var=1.0, P0="diffuse")
    with pytest.warns(AdaptidWarning, match="lower bound"):
        fit = est.fit_variances(Phi, y, per_parameter=True)
    assert fit.process_var[0] < 1e-3 * fit.process_var[1]
    assert np.isnan(fit.stderr[0]) and np.isfinite(fit.stderr[1:]).all()


# ------------------------------------------------------ results and refusals
def test_results_follow_the_convention(data):
    pd = pytest.importorskip("pandas")
    pytest.importorskip("matplotlib")
    from matplotlib.figure import Figure
    Phi, y, theta = data
    time = pd.date_range("2026-01-01", periods=N, freq="s")
    df = pd.DataFrame(Phi, columns=["a", "b", "c"], index=time)
    res = _est(False).smooth(df, pd.Series(y, index=time))
    frame = res.to_frame()
    assert frame.index.name == "time" and (frame.index == time).all()
    assert list(frame.columns[:4]) == ["a", "a_stderr", "a_filtered", "a_filtered_stderr"]
    np.testing.assert_array_equal(frame["b"], res.theta[:, 1])
    np.testing.assert_array_equal(frame["c_stderr"], np.sqrt(res.P[:, 2, 2]))
    assert isinstance(res.plot(true_theta=theta), Figure)
    s = res.summary()
    assert s.names == ("a", "b", "c") and s["N"] == N
    np.testing.assert_array_equal(s.params[:, 0], res.theta[-1])
    fit = _est(True).fit_variances(Phi, y)
    assert "noise_var" in str(fit.summary())
    assert list(fit.to_frame().index) == ["process_var", "noise_var"]
    np.testing.assert_array_equal(fit.to_frame()["stderr"], fit.stderr)


def test_refusals(data):
    Phi, y, _ = data
    with pytest.raises(ValueError, match="Phi"):
        _est(False).smooth(Phi[:, :2], y)
    with pytest.raises(ValueError, match="y"):
        _est(False).loglike(Phi, y[:-1])
    with pytest.raises(ValueError, match="y"):
        KalmanRLS(n, process_cov=Q, n_outputs=2).smooth(Phi, np.column_stack([y, y]))
    with pytest.raises(ValueError, match="method"):
        _est(False).fit_variances(Phi, y, method="newton")
    with pytest.raises(ValueError, match="weights"):
        _est(False).smooth(Phi, y, weights=-1.0)


def test_gemm_with_beta_zero_never_reads_out():
    """The backward pass's work arrays come from ``np.empty``: with β = 0 the
    product must overwrite them (0·NaN is NaN; CI's allocator gave NaN garbage)."""
    from adaptid._kernels.recursions._smoother import _gemm
    rng = np.random.default_rng(3)
    A, B = rng.standard_normal((2, 4, 4))
    out = np.full((4, 4), np.nan)
    _gemm(A, True, B, False, 2.0, 0.0, out)
    np.testing.assert_allclose(out, 2.0 * A.T @ B, rtol=1e-14, atol=1e-14)
    out2 = np.ones((4, 4))
    _gemm(A, False, B, True, 1.0, 1.0, out2)
    np.testing.assert_allclose(out2, 1.0 + A @ B.T, rtol=1e-14, atol=1e-14)

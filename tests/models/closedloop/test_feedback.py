"""checkfeedback (issue 37, point 2) against NumPy and by Monte Carlo."""

import numpy as np
import pytest
from scipy import linalg, stats
from scipy.signal import lfilter

from adaptid.models import FeedbackResult, IDData, checkfeedback


def closed_loop(N, seed, K=0.4, sd=0.5):
    """y = 0.5 q⁻¹/(1 − 0.8 q⁻¹) u + e/(1 − 0.8 q⁻¹), u = r − K y (white r, e)."""
    rng = np.random.default_rng(seed)
    r, e = rng.standard_normal(N), sd * rng.standard_normal(N)
    y, u = np.zeros(N), np.zeros(N)
    for k in range(N):
        y[k] = (0.8 * y[k - 1] + 0.5 * u[k - 1] if k else 0.0) + e[k]
        u[k] = r[k] - K * y[k]
    return y, u, r


def open_loop(N, seed):
    """Coloured input (AR(1), pole 0.9) and coloured ARMA noise, no feedback."""
    rng = np.random.default_rng(seed)
    u = lfilter([1], [1, -0.9], rng.standard_normal(N))
    y = lfilter([0, 0.5], [1, -0.8], u) + lfilter([1, 0.5], [1, -0.7], 0.5 * rng.standard_normal(N))
    return y, u


def test_statistic_against_numpy():
    y, u, _ = closed_loop(800, 1)
    n, M = 6, 12
    res = checkfeedback((y, u), max_lag=M, order=n)
    # the ARX(6, 6, 1) rows k = 6 … N-1 by hand, least squares by numpy
    Phi = np.column_stack([-y[n - j: y.size - j] for j in range(1, n + 1)]
                          + [u[n - j: y.size - j] for j in range(1, n + 1)])
    e = y[n:] - Phi @ np.linalg.lstsq(Phi, y[n:], rcond=None)[0]
    ue = u[n:]
    ec, uc = e - e.mean(), ue - ue.mean()
    N = e.size
    r = np.array([np.sum(ec[:N - t] * uc[t:]) for t in range(1, M + 1)])
    r /= np.sqrt(np.sum(ec ** 2) * np.sum(uc ** 2))
    T = linalg.toeplitz([np.sum(uc[:N - t] * uc[t:]) / np.sum(uc ** 2) for t in range(M)])
    stat = N * r @ np.linalg.solve(T, r)
    assert res.n_obs == N and res.dof == M
    assert np.allclose(res.residuals, e, atol=1e-10)
    assert np.allclose(res.ccf, r, atol=1e-12)
    assert np.isclose(res.statistic, stat, rtol=1e-10)
    assert np.isclose(res.p_value, stats.chi2.sf(stat, M), rtol=1e-8)
    assert res.feedback == (res.p_value < 0.05)
    assert np.isclose(res.band, stats.norm.ppf(0.975) / np.sqrt(N))


def test_level_without_feedback_and_why_the_toeplitz_weighting():
    # 200 open-loop records, strongly coloured input: the test rejects at about its level
    rej, naive, pvals = 0, 0, []
    for i in range(200):
        y, u = open_loop(600, 1000 + i)
        res = checkfeedback((y, u), alpha=0.05)
        rej += res.feedback
        pvals.append(res.p_value)
        # N Σ r(τ)² ignores the correlation between lags that the input's colour causes
        naive += stats.chi2.sf(res.n_obs * np.sum(res.ccf ** 2), res.dof) < 0.05
    # binomial(200, 0.05): mean 10, sd 3.1; 20 rejections would be 3 sd above
    assert rej <= 20
    assert 0.35 < np.mean(pvals) < 0.65
    assert naive > 3 * max(rej, 5)


def test_power_in_closed_loop():
    hits = sum(checkfeedback(closed_loop(2000, 50 + i)[:2]).feedback for i in range(20))
    assert hits >= 18
    # the reference is not fed back: (y, r) is an open-loop record
    clean = sum(checkfeedback((y, r)).feedback for y, _, r in
                (closed_loop(2000, 50 + i) for i in range(20)))
    assert clean <= 4


def test_a_direct_term_needs_nk_0():
    # open loop, plant with a direct term b0 u(k) and a coloured input: nk = 1 leaves
    # b0 u(k) in the residual, which correlates with u(k + τ), a false alarm; nk = 0 does not
    wrong, right = 0, 0
    for i in range(20):
        rng = np.random.default_rng(300 + i)
        u = lfilter([1], [1, -0.9], rng.standard_normal(1500))
        y = lfilter([1.0, 0.5], [1, -0.8], u) + 0.5 * rng.standard_normal(1500)
        wrong += checkfeedback((y, u)).feedback
        right += checkfeedback((y, u), nk=0).feedback
    assert wrong >= 18 and right <= 3


def test_result_convention():
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    y, u, _ = closed_loop(1500, 7)
    res = checkfeedback(IDData(y, u, dt=0.1), max_lag=10)
    assert isinstance(res, FeedbackResult) and res.feedback
    text = res.summary()
    assert "p-value" in text and "feedback" in text
    df = res.to_frame()
    assert list(df.columns) == ["lag", "ccf", "band", "outside"] and len(df) == 10
    assert np.array_equal(df["lag"], np.arange(1, 11))
    fig = res.plot()
    assert isinstance(fig, Figure)
    assert repr(res).startswith("FeedbackResult(feedback=True")


def test_errors_name_the_argument():
    y, u, r = closed_loop(400, 0)
    with pytest.raises(ValueError, match="data"):
        checkfeedback(IDData(y, np.column_stack([u, r])))
    with pytest.raises(ValueError, match="alpha"):
        checkfeedback((y, u), alpha=1.5)
    with pytest.raises(ValueError, match="order"):
        checkfeedback((y, u), order=0)
    with pytest.raises(ValueError, match="max_lag"):
        checkfeedback((y, u), max_lag=0)
    with pytest.raises(ValueError, match="data"):
        checkfeedback((y[:60], u[:60]))
    with pytest.raises(ValueError, match="input is not constant"):
        checkfeedback((y, np.ones_like(y)))

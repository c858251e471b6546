"""Regularised FIR / ARX (issue 37, point 3) against plain-NumPy oracles."""

import time

import numpy as np
import pytest
from scipy.signal import lfilter
from scipy.stats import multivariate_normal

from adaptid.models import ARX, arx_regul, impulseest, kernel_matrix

B, A = [0, 1.0, 0.5], [1, -1.2, 0.5]      # a stable 2nd-order system (poles 0.6 ± 0.37j)


def _record(N, seed, sd=0.3):
    rng = np.random.default_rng(seed)
    u = rng.standard_normal(N)
    return lfilter(B, A, u) + sd * rng.standard_normal(N), u


def _fir_rows(y, u, n, nk):
    s = nk + n - 1
    Phi = np.column_stack([u[s - nk - j: y.size - nk - j] for j in range(n)])
    return Phi, y[s:]


@pytest.mark.parametrize("kernel,h", [("TC", (2.0, 0.8)), ("DC", (1.5, 0.85, 0.6)),
                                      ("SS", (3.0, 0.9))])
def test_fixed_hyperparameters_bayes_formula(kernel, h):
    # the posterior mean and covariance in NumPy with explicit inverses (fine in a test)
    y, u = _record(150, 0, sd=0.2)
    n, nk, s2 = 20, 1, 0.04
    m = impulseest((y, u), n, nk=nk, kernel=kernel, hyperparameters=h, noise_variance=s2)
    Phi, yv = _fir_rows(y, u, n, nk)
    i = np.arange(1, n + 1)
    mx = np.maximum.outer(i, i)
    ipj, imj = np.add.outer(i, i), np.abs(np.subtract.outer(i, i))
    P = {"TC": lambda: h[0] * h[1] ** mx,
         "DC": lambda: h[0] * h[1] ** (ipj / 2) * h[2] ** imj,
         "SS": lambda: h[0] * (h[1] ** (ipj + mx) / 2 - h[1] ** (3 * mx) / 6)}[kernel]()
    assert np.allclose(kernel_matrix(kernel, n, h), P, rtol=1e-14, atol=0)
    if kernel != "SS":   # SS at λ = 0.9 and n = 20 is too ill-conditioned for an explicit P⁻¹
        post = np.linalg.inv(Phi.T @ Phi + s2 * np.linalg.inv(P))
        theta = post @ Phi.T @ yv
        assert np.allclose(m.theta, theta, rtol=0, atol=1e-10)
        assert np.allclose(m.cov, s2 * post, rtol=0, atol=1e-10)
    # the form without P⁻¹: θ = PΦᵀ(ΦPΦᵀ + σ²I)⁻¹y, valid for every P
    S = Phi @ P @ Phi.T + s2 * np.eye(yv.size)
    theta2 = P @ Phi.T @ np.linalg.solve(S, yv)
    cov2 = P - P @ Phi.T @ np.linalg.solve(S, Phi @ P)
    assert np.allclose(m.theta, theta2, rtol=0, atol=1e-10)
    assert np.allclose(m.cov, cov2, rtol=0, atol=1e-10)
    assert np.allclose(m.stderr, np.sqrt(np.diag(cov2)), rtol=1e-8)
    # the marginal likelihood against the dense N × N Gaussian (tolerance: 1e-8 absolute)
    dense = multivariate_normal(mean=np.zeros(yv.size), cov=S).logpdf(yv)
    assert abs(m.marginal_loglik - dense) < 1e-8


def test_tuned_hyperparameters_maximise_the_marginal_likelihood():
    y, u = _record(200, 3)
    m = impulseest((y, u), 30, kernel="TC")
    ll = m.marginal_loglik
    c, lam = m.hyperparameters
    for dc, dl in [(1.2, 1.0), (0.8, 1.0), (1.0, 0.98), (1.0, 1.01)]:
        if lam * dl < 1:
            other = impulseest((y, u), 30, kernel="TC", hyperparameters=(c * dc, lam * dl),
                               noise_variance=m.noise_variance)
            assert other.marginal_loglik <= ll + 1e-6
    # σ² default: the plain least-squares FIR's residual variance
    assert np.isclose(m.noise_variance, ARX(0, 30, 0).fit(y, u).noise_variance, rtol=1e-12)


def test_monte_carlo_mse_below_least_squares():
    # 50 records of N = 100, a 50-tap FIR of a stable 2nd-order system
    t0 = time.perf_counter()
    n, nk = 50, 0
    g = lfilter(B, A, np.r_[1.0, np.zeros(n - 1)])
    mse_ls, mse = {"TC": [], "DC": [], "SS": []}, []
    for r in range(50):
        y, u = _record(150, 100 + r, sd=0.5)    # N − s = 101 rows
        ls = ARX(0, n, nk).fit(y, u).theta
        mse.append(np.mean((ls - g) ** 2))
        for k in mse_ls:
            mse_ls[k].append(np.mean((impulseest((y, u), n, nk=nk, kernel=k).theta - g) ** 2))
    for k, v in mse_ls.items():
        assert np.mean(v) < 0.5 * np.mean(mse), k
    assert time.perf_counter() - t0 < 60


def test_arx_regul_fixed_hyperparameters_block_prior():
    rng = np.random.default_rng(5)
    u, e = rng.standard_normal(300), 0.1 * rng.standard_normal(300)
    y = lfilter(B, A, u) + lfilter([1], A, e)
    h = (5.0, 0.5, 2.0, 0.7)
    m = arx_regul((y, u), 2, 8, 1, hyperparameters=h, noise_variance=0.01)
    ref = ARX(2, 8, 1).fit(y, u)
    Phi = np.column_stack([-y[7 - j: 299 - j] for j in range(2)]
                          + [u[8 - 1 - j: 300 - 1 - j] for j in range(8)])
    yv = y[8:]
    assert np.allclose(Phi @ ref.theta, yv - ref.residuals)     # the same rows as ARX
    P = np.zeros((10, 10))
    P[:2, :2] = 5.0 * 0.5 ** np.maximum.outer([1, 2], [1, 2])
    P[2:, 2:] = 2.0 * 0.7 ** np.maximum.outer(np.arange(1, 9), np.arange(1, 9))
    theta = np.linalg.solve(Phi.T @ Phi + 0.01 * np.linalg.inv(P), Phi.T @ yv)
    assert np.allclose(m.theta, theta, atol=1e-10)
    assert m.names == ref.names
    tuned = arx_regul((y, u), 2, 8, 1)
    assert tuned.hyperparameters.shape == (4,)
    assert np.allclose(tuned.theta[:4], [-1.2, 0.5, 1.0, 0.5], atol=0.1)


def test_errors_name_the_argument():
    y, u = _record(100, 0)
    with pytest.raises(ValueError, match="kernel"):
        impulseest((y, u), 10, kernel="XX")
    with pytest.raises(ValueError, match="hyperparameters"):
        impulseest((y, u), 10, hyperparameters=(1.0, 1.5))
    with pytest.raises(ValueError, match="hyperparameters"):
        impulseest((y, u), 10, kernel="DC", hyperparameters=(1.0, 0.5))
    with pytest.raises(ValueError, match="noise_variance"):
        impulseest((y, u), 10, noise_variance=-1.0)
    with pytest.raises(ValueError, match="n must"):
        impulseest((y, u), 0)
    with pytest.raises(ValueError, match="noise_variance"):
        impulseest((y[:40], u[:40]), 30)


def test_iddata_carries_dt_and_names():
    from adaptid.models import IDData

    y, u = _record(200, 9)
    m = impulseest(IDData(y, u, dt=0.1), 15, nk=1, kernel="DC")
    assert m.dt == 0.1 and m.names[0] == "b0" and m.hyperparameters.shape == (3,)
    assert np.allclose(m.theta, impulseest(y, 15, u=u, nk=1, kernel="DC").theta)
    assert m.to_control().dt == 0.1

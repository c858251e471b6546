"""SE, HF and DI kernels of impulseest / arx_regul (issue 37, point 3) against NumPy."""

import numpy as np
import pytest
from scipy.signal import lfilter
from scipy.stats import multivariate_normal

from adaptid.models import arx_regul, impulseest, kernel_matrix

B, A = [0, 1.0, 0.5], [1, -1.2, 0.5]


def _record(N, seed, sd=0.3, b=B, a=A):
    rng = np.random.default_rng(seed)
    u = rng.standard_normal(N)
    return lfilter(b, a, u) + sd * rng.standard_normal(N), u


def _fir_rows(y, u, n, nk):
    s = nk + n - 1
    Phi = np.column_stack([u[s - nk - j: y.size - nk - j] for j in range(n)])
    return Phi, y[s:]


def _numpy_kernel(kernel, n, h):
    """The kernels written out entry by entry (as the loops of the rfir MATLAB code)."""
    P = np.zeros((n, n))
    for i in range(1, n + 1):
        for j in range(1, n + 1):
            if kernel == "SE":
                P[i - 1, j - 1] = h[0] * np.exp(-(i - j) ** 2 / (2 * h[1] ** 2))
            elif kernel == "HF":
                P[i - 1, j - 1] = h[0] * (1 if (i + j) % 2 == 0 else -1) * min(h[1] ** i, h[1] ** j)
            elif i == j:                                    # DI
                P[i - 1, j - 1] = h[0] * h[1] ** i
    return P


@pytest.mark.parametrize("kernel,h", [("SE", (0.5, 3.0)), ("HF", (2.0, 0.8)), ("DI", (1.5, 0.7))])
def test_fixed_hyperparameters_bayes_formula(kernel, h):
    y, u = _record(150, 0, sd=0.2)
    n, nk, s2 = 20, 1, 0.04
    P = _numpy_kernel(kernel, n, h)
    assert np.allclose(kernel_matrix(kernel, n, h), P, rtol=1e-14, atol=1e-300)
    m = impulseest((y, u), n, nk=nk, kernel=kernel, hyperparameters=h, noise_variance=s2)
    Phi, yv = _fir_rows(y, u, n, nk)
    # θ = PΦᵀ(ΦPΦᵀ + σ²I)⁻¹y and the posterior covariance, dense N × N (valid for singular P)
    S = Phi @ P @ Phi.T + s2 * np.eye(yv.size)
    theta = P @ Phi.T @ np.linalg.solve(S, yv)
    cov = P - P @ Phi.T @ np.linalg.solve(S, Phi @ P)
    assert np.allclose(m.theta, theta, rtol=0, atol=1e-9)
    assert np.allclose(m.cov, cov, rtol=0, atol=1e-9)
    if kernel != "SE":   # SE at β = 3, n = 20 is too ill-conditioned for an explicit P⁻¹
        post = np.linalg.inv(Phi.T @ Phi + s2 * np.linalg.inv(P))
        assert np.allclose(m.theta, post @ Phi.T @ yv, rtol=0, atol=1e-9)
    # the marginal likelihood against the dense Gaussian density (1e-8 absolute)
    dense = multivariate_normal(mean=np.zeros(yv.size), cov=S).logpdf(yv)
    assert abs(m.marginal_loglik - dense) < 1e-8


@pytest.mark.parametrize("kernel", ["SE", "HF", "DI"])
def test_tuned_hyperparameters_are_a_local_maximum(kernel):
    y, u = _record(200, 3)
    m = impulseest((y, u), 25, kernel=kernel)
    c, p = m.hyperparameters
    for dc, dp in [(1.2, 1.0), (0.8, 1.0), (1.0, 0.97), (1.0, 1.03)]:
        if kernel == "SE" or p * dp < 1:
            other = impulseest((y, u), 25, kernel=kernel, hyperparameters=(c * dc, p * dp),
                               noise_variance=m.noise_variance)
            assert other.marginal_loglik <= m.marginal_loglik + 1e-6


def test_hf_kernel_suits_an_oscillating_impulse_response():
    # g_k = (-0.85)^k: HF's prior has the alternating sign, TC's has not
    b, a = [0, 1.0], [1, 0.85]
    n = 40
    g = lfilter(b, a, np.r_[1.0, np.zeros(n - 1)])
    err = {"HF": [], "TC": []}
    for r in range(10):
        y, u = _record(120, 40 + r, sd=0.5, b=b, a=a)
        for k in err:
            err[k].append(np.mean((impulseest((y, u), n, kernel=k).theta - g) ** 2))
    assert np.mean(err["HF"]) < np.mean(err["TC"])


def test_arx_regul_accepts_the_new_kernels():
    rng = np.random.default_rng(5)
    u, e = rng.standard_normal(400), 0.1 * rng.standard_normal(400)
    y = lfilter(B, A, u) + lfilter([1], A, e)
    for kernel in ("SE", "HF", "DI"):
        m = arx_regul((y, u), 2, 8, 1, kernel=kernel)
        assert m.kernel == kernel and m.hyperparameters.shape == (4,)
    h = (2.0, 0.5, 1.0, 0.6)
    m = arx_regul((y, u), 2, 8, 1, kernel="DI", hyperparameters=h, noise_variance=0.01)
    P = np.diag(np.r_[2.0 * 0.5 ** np.arange(1, 3), 1.0 * 0.6 ** np.arange(1, 9)])
    # rows k = 8 … 399: [-y[k-1], -y[k-2], u[k-1], …, u[k-8]]
    Phi = np.column_stack([-y[7 - j: 399 - j] for j in range(2)]
                          + [u[7 - j: 399 - j] for j in range(8)])
    yv = y[8:]
    theta = np.linalg.solve(Phi.T @ Phi + 0.01 * np.linalg.inv(P), Phi.T @ yv)
    assert np.allclose(m.theta, theta, atol=1e-10)


def test_errors_name_the_argument():
    y, u = _record(100, 0)
    with pytest.raises(ValueError, match="beta > 0"):
        impulseest((y, u), 10, kernel="SE", hyperparameters=(1.0, -2.0))
    with pytest.raises(ValueError, match="lam in"):
        kernel_matrix("HF", 4, (1.0, 1.0))
    with pytest.raises(ValueError, match="hyperparameters"):
        kernel_matrix("DI", 4, (1.0,))
    with pytest.raises(ValueError, match="'SE', 'HF', 'DI'"):
        impulseest((y, u), 10, kernel="CS")

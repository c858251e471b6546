"""Instrumental variables (issue 37, point 1): iv4 and ivx against NumPy oracles."""

import time

import numpy as np
import pytest
from scipy.signal import lfilter

from adaptid.models import ARX, iv4, ivx

A, B, C = [1, -0.8], [0, 1.0], [1, 0.9]   # ARX(1, 1, 1) with MA(1) equation noise


def _record(N, seed):
    rng = np.random.default_rng(seed)
    u, e = rng.standard_normal(N), rng.standard_normal(N)
    return lfilter(B, A, u) + lfilter(C, A, e), u


def _rows(y, u, na, nb, nk):
    """ARX rows [-y lags, u lags] for k = s … N-1 written out."""
    s = max(na, nk + nb - 1)
    N = y.size
    cols = [-y[s - j: N - j] for j in range(1, na + 1)]
    cols += [u[s - nk - j: N - nk - j] for j in range(nb)]
    return np.column_stack(cols), y[s:]


def _iv4_numpy(y, u, na, nb, nk):
    """Ljung's four stages, plain NumPy (explicit inverses are fine here)."""
    Phi, yv = _rows(y, u, na, nb, nk)
    th1 = np.linalg.lstsq(Phi, yv, rcond=None)[0]
    x = lfilter(np.r_[np.zeros(nk), th1[na:]], np.r_[1.0, th1[:na]], u)
    Z, _ = _rows(x, u, na, nb, nk)
    th2 = np.linalg.inv(Z.T @ Phi) @ Z.T @ yv
    v = yv - Phi @ th2
    nl = na + nb
    V = np.column_stack([-v[nl - j: v.size - j] for j in range(1, nl + 1)])
    ell = np.linalg.lstsq(V, v[nl:], rcond=None)[0]
    L = np.r_[1.0, ell]
    x = lfilter(np.r_[np.zeros(nk), th2[na:]], np.r_[1.0, th2[:na]], u)
    yf, uf, xf = (lfilter(L, [1.0], s) for s in (y, u, x))
    Phif, yfv = _rows(yf, uf, na, nb, nk)
    Zf, _ = _rows(xf, uf, na, nb, nk)
    Si = np.linalg.inv(Zf.T @ Phif)
    th4 = Si @ Zf.T @ yfv
    eps = yfv - Phif @ th4
    s2 = eps @ eps / (eps.size - th4.size)
    return th4, s2 * Si @ (Zf.T @ Zf) @ Si.T, L


@pytest.mark.parametrize("na,nb,nk", [(1, 1, 1), (2, 3, 1), (2, 2, 0), (1, 2, 3)])
def test_iv4_equals_its_four_stages(na, nb, nk):
    y, u = _record(800, na * 10 + nb + nk)
    m = iv4((y, u), na, nb, nk)
    th, cov, L = _iv4_numpy(y, u, na, nb, nk)
    assert np.allclose(m.theta, th, rtol=0, atol=1e-10)
    assert np.allclose(m.cov, cov, rtol=1e-9, atol=1e-14)
    assert np.allclose(m.prefilter, L, rtol=0, atol=1e-10)
    Phi, yv = _rows(y, u, na, nb, nk)
    assert np.allclose(m.residuals, yv - Phi @ th, atol=1e-10)
    assert m.method == "iv4"


def test_ivx_signal_and_matrix_instruments():
    y, u = _record(600, 7)
    x = lfilter(B, A, u)
    m = ivx((y, u), 1, 2, 1, x)
    Phi, yv = _rows(y, u, 1, 2, 1)
    Z, _ = _rows(x, u, 1, 2, 1)
    Si = np.linalg.inv(Z.T @ Phi)
    th = Si @ Z.T @ yv
    eps = yv - Phi @ th
    cov = eps @ eps / (eps.size - 3) * Si @ (Z.T @ Z) @ Si.T
    assert np.allclose(m.theta, th, atol=1e-10)
    assert np.allclose(m.cov, cov, rtol=1e-9, atol=1e-14)
    m2 = ivx((y, u), 1, 2, 1, Z)
    assert np.allclose(m2.theta, th, atol=1e-10)
    # instruments equal to the regressors: least squares
    m3 = ivx((y, u), 1, 2, 1, y)
    assert np.allclose(m3.theta, ARX(1, 2, 1).fit(y, u).theta, atol=1e-10)
    with pytest.raises(ValueError, match="instruments"):
        ivx((y, u), 1, 2, 1, x[:-1])
    with pytest.raises(ValueError, match="instruments"):
        ivx((y, u), 1, 2, 1, Z[:, :2])


def test_monte_carlo_iv_consistent_where_least_squares_is_biased():
    # ARX(1, 1, 1) with MA(1) noise: LS biased, IV consistent (Ljung 1999, sec. 7.6)
    t0 = time.perf_counter()
    truth = np.array([-0.8, 1.0])
    ls, iv, ivx_, sd = [], [], [], []
    for r in range(100):
        y, u = _record(2000, 1000 + r)
        ls.append(ARX(1, 1, 1).fit(y, u).theta)
        m = iv4((y, u), 1, 1, 1)
        iv.append(m.theta)
        sd.append(m.stderr)
        ivx_.append(ivx((y, u), 1, 1, 1, lfilter(B, A, u)).theta)
    for est, consistent in [(ls, False), (iv, True), (ivx_, True)]:
        est = np.asarray(est)
        se = est.std(axis=0, ddof=1) / np.sqrt(len(est))
        inside = np.abs(est.mean(axis=0) - truth) < 3 * se
        # least squares: a1 biased (b0 is not: u is white and enters with a delay)
        assert inside.all() if consistent else not inside[0]
    # the reported iv4 standard errors match the Monte Carlo spread (±25 % for 100 runs)
    assert np.allclose(np.mean(sd, axis=0), np.std(iv, axis=0, ddof=1), rtol=0.25)
    assert time.perf_counter() - t0 < 30

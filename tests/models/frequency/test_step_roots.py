"""Step responses and poles/zeros with standard deviations (issue 36, point 1)."""

import numpy as np
import pytest
from scipy.signal import lfilter

from adaptid.models import ARX, OE, Roots, StepResponse


def _fir(rng, N=400):
    u = rng.standard_normal(N)
    y = lfilter([0.0, 0.8, -0.3, 0.2], [1.0], u) + 0.2 * rng.standard_normal(N)
    return ARX(0, 3, 1, dt=0.5).fit(y, u)


def _oe(rng, N=600, noise=0.1):
    u = rng.standard_normal(N)
    y = lfilter([0.0, 1.0, 0.5], [1.0, -1.2, 0.5], u) + noise * rng.standard_normal(N)
    return OE(2, 2, 1).fit(y, u)


def test_fir_step_sd_equals_closed_form():
    m = _fir(np.random.default_rng(1))
    sr = m.step_response(12)
    # s_t = sum_{k+1 <= t} b_k: linear in θ, s = L θ with L the cumulative-sum matrix
    L = (np.arange(12)[:, None] >= np.arange(1, 4)[None, :]).astype(float)
    np.testing.assert_allclose(sr.response, L @ m.theta, rtol=0, atol=1e-12)
    np.testing.assert_allclose(sr.sd, np.sqrt(np.diag(L @ m.cov @ L.T)), rtol=0, atol=1e-12)
    np.testing.assert_allclose(sr.t, 0.5 * np.arange(12))


def test_step_equals_python_control():
    control = pytest.importorskip("control")
    m = _oe(np.random.default_rng(2))
    sr = m.step_response()
    ref = control.step_response(m.to_control(), T=sr.t)
    np.testing.assert_allclose(sr.response, np.squeeze(ref.outputs), rtol=0, atol=1e-10)


def test_step_sd_against_finite_differences():
    m = _oe(np.random.default_rng(3))
    T = 40
    sr = m.step_response(T)
    th = m.theta.copy()
    J = np.zeros((T, th.size))
    h = 1e-6
    for j in range(th.size):
        e = np.zeros(th.size)
        e[j] = h
        m.theta = th + e
        sp = m.step_response(T).response
        m.theta = th - e
        sm = m.step_response(T).response
        J[:, j] = (sp - sm) / (2 * h)
    m.theta = th
    sd = np.sqrt(np.diag(J @ m.cov @ J.T))
    np.testing.assert_allclose(sr.sd, sd, rtol=1e-6, atol=1e-12)


def test_default_length_and_results():
    m = _oe(np.random.default_rng(4))
    sr = m.step_response()
    r = np.max(np.abs(np.roots(m.F)))
    assert sr.t.size == int(np.ceil(-10 / np.log(r))) + m.B.size
    assert isinstance(sr, StepResponse)
    df = sr.to_frame()
    assert list(df.columns) == ["t", "response", "sd"]
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    fig = sr.plot(sd=3)
    ax = fig.axes[0]
    assert ax.get_xlabel() == "time (s)" and ax.get_title() == "u → y"
    assert _fir(np.random.default_rng(0)).step_response().t.size == 20   # FIR: at least 20


def test_step_several_inputs():
    rng = np.random.default_rng(5)
    U = rng.standard_normal((500, 2))
    y = (lfilter([0.0, 1.0], [1.0, -0.5], U[:, 0]) + lfilter([0.0, -0.5], [1.0, -0.5], U[:, 1])
         + 0.05 * rng.standard_normal(500))
    m = ARX(1, [1, 1], [1, 1]).fit(y, U)
    sr = m.step_response(15)
    assert sr.response.shape == (1, 2, 15) and sr.sd.shape == (1, 2, 15)
    for i in range(2):
        e = np.zeros((15, 2))
        e[:, i] = 1.0
        np.testing.assert_allclose(sr.response[0, i], m.simulate(e), atol=1e-12)
    assert len(sr.to_frame()) == 30
    assert len(m.poles()) == 2 and isinstance(m.poles()[0], Roots)


def _sorted_roots(r):
    r = np.asarray(r)
    return r[np.lexsort((r.imag, r.real))]


def test_roots_sd_against_finite_differences():
    m = _oe(np.random.default_rng(6))
    for which in ("poles", "zeros"):
        R = getattr(m, which)()
        vals = _sorted_roots(R.values)
        order = np.lexsort((R.values.imag, R.values.real))
        th = m.theta.copy()
        G = np.zeros((vals.size, th.size), dtype=complex)
        h = 1e-7
        for j in range(th.size):
            e = np.zeros(th.size)
            e[j] = h
            m.theta = th + e
            rp = _sorted_roots(getattr(m, which)().values)
            m.theta = th - e
            rm = _sorted_roots(getattr(m, which)().values)
            G[:, j] = (rp - rm) / (2 * h)
        m.theta = th
        sr = np.sqrt(np.einsum("ri,ij,rj->r", G.real, m.cov, G.real))
        si = np.sqrt(np.einsum("ri,ij,rj->r", G.imag, m.cov, G.imag))
        np.testing.assert_allclose(R.sd_real[order], sr, rtol=1e-5)
        np.testing.assert_allclose(R.sd_imag[order], si, rtol=1e-5, atol=1e-12)
    assert np.iscomplexobj(m.poles().values) and np.all(m.poles().sd_imag > 0)


def test_roots_sd_monte_carlo():
    m = _oe(np.random.default_rng(7))
    P = m.poles()
    draws = np.array([_sorted_roots(s.poles().values) for s in m.rsample(4000, seed=1)])
    order = np.lexsort((P.values.imag, P.values.real))
    # 4000 draws: the sample sd is within ~2.5 % (1 sd); first-order error is smaller
    np.testing.assert_allclose(draws.real.std(axis=0), P.sd_real[order], rtol=0.1)
    np.testing.assert_allclose(np.abs(draws.imag).std(axis=0), P.sd_imag[order], rtol=0.1)
    Z = m.zeros()
    z = np.array([s.zeros().values for s in m.rsample(4000, seed=2)])
    np.testing.assert_allclose(z.real.std(axis=0), Z.sd_real, rtol=0.1)
    assert list(Z.to_frame().columns) == ["real", "imag", "abs", "sd_real", "sd_imag"]

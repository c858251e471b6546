"""Frequency responses (issue 36): freqresp with bands, rsample, spa, etfe."""

import numpy as np
import pytest
from scipy.signal import lfilter

from adaptid.models import ARX, AR, ARMA, ARMAX, BJ, OE, FrequencyResponse, IDData, etfe, spa


def _arx_data(N, rng, noise=0.3):
    u = rng.standard_normal(N)
    e = noise * rng.standard_normal(N)
    y = lfilter([0.0, 1.0, 0.5], [1.0, -0.6], u) + lfilter([1.0], [1.0, -0.6], e)
    return y, u


# ------------------------------------------------------------------ freqresp
def test_fir_covariance_equals_closed_form():
    rng = np.random.default_rng(1)
    u = rng.standard_normal(400)
    y = lfilter([0.0, 0.8, -0.3, 0.2], [1.0], u) + 0.2 * rng.standard_normal(400)
    m = ARX(0, 3, 1, dt=0.5).fit(y, u)
    w = np.linspace(0.1, np.pi / 0.5, 17)
    fr = m.freqresp(w)
    # G = sum_k b_k e^{-iω(k+1)dt}: linear in θ, J exact
    E = np.exp(-1j * np.outer(w * 0.5, np.arange(1, 4)))
    np.testing.assert_allclose(fr.response, E @ m.theta, rtol=0, atol=1e-12)
    S = m.cov
    c_rr = np.einsum("wi,ij,wj->w", E.real, S, E.real)
    c_ri = np.einsum("wi,ij,wj->w", E.real, S, E.imag)
    c_ii = np.einsum("wi,ij,wj->w", E.imag, S, E.imag)
    G = E @ m.theta
    x, yy = G.real, G.imag
    r = np.abs(G)
    msd = np.sqrt(x * x * c_rr + 2 * x * yy * c_ri + yy * yy * c_ii) / r
    psd = np.sqrt(yy * yy * c_rr - 2 * x * yy * c_ri + x * x * c_ii) / r ** 2
    np.testing.assert_allclose(fr.magnitude_sd, msd, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(fr.phase_sd, psd, rtol=1e-12, atol=1e-14)


def _numeric_sd(model, w, h=1e-6):
    """Finite-difference Jacobian (only as an independent check of the analytic one)."""
    th0 = model.theta.copy()
    G0 = model.freqresp(w).response
    J = np.zeros((w.size, th0.size), dtype=complex)
    for j in range(th0.size):
        model.theta = th0.copy()
        model.theta[j] += h
        Gp = model.freqresp(w).response
        model.theta[j] -= 2 * h
        Gm = model.freqresp(w).response
        J[:, j] = (Gp - Gm) / (2 * h)
    model.theta = th0
    S = model.cov
    crr = np.einsum("wi,ij,wj->w", J.real, S, J.real)
    cri = np.einsum("wi,ij,wj->w", J.real, S, J.imag)
    cii = np.einsum("wi,ij,wj->w", J.imag, S, J.imag)
    x, y = G0.real, G0.imag
    return np.sqrt(x * x * crr + 2 * x * y * cri + y * y * cii) / np.abs(G0)


@pytest.mark.parametrize("make", [lambda: ARX(2, 2, 1), lambda: OE(2, 2, 1),
                                  lambda: ARMAX(1, 2, 1, 1), lambda: BJ(2, 1, 1, 1, 1)])
def test_analytic_jacobian_matches_finite_differences(make):
    rng = np.random.default_rng(2)
    y, u = _arx_data(600, rng)
    m = make().fit(y, u)
    w = np.linspace(0.05, 3.0, 9)
    np.testing.assert_allclose(m.freqresp(w).magnitude_sd, _numeric_sd(m, w), rtol=1e-5)


def test_freqresp_equals_python_control():
    control = pytest.importorskip("control")
    rng = np.random.default_rng(3)
    y, u = _arx_data(500, rng)
    for m in (ARX(2, 2, 1, dt=0.1).fit(y, u), OE(2, 2, 2, dt=0.1).fit(y, u)):
        fr = m.freqresp()
        np.testing.assert_allclose(fr.w, np.arange(1, 129) / 128 * np.pi / 0.1)
        ref = control.frequency_response(m.to_control(), fr.w)
        np.testing.assert_allclose(fr.response, np.squeeze(ref.complex), rtol=1e-10, atol=1e-12)


def test_freqresp_time_series_is_noise_model():
    control = pytest.importorskip("control")
    rng = np.random.default_rng(4)
    y = lfilter([1.0, 0.4], [1.0, -0.5], rng.standard_normal(800))
    for m in (AR(2).fit(y), ARMA(1, 1).fit(y)):
        fr = m.freqresp()
        ref = control.frequency_response(m.to_control(), fr.w)
        np.testing.assert_allclose(fr.response, np.squeeze(ref.complex), rtol=1e-10, atol=1e-12)
        assert fr.u_names == ("e",) and np.all(fr.magnitude_sd > 0)


def test_freqresp_several_inputs_shape():
    rng = np.random.default_rng(5)
    U = rng.standard_normal((400, 2))
    y = (lfilter([0, 1.0], [1, -0.5], U[:, 0]) + lfilter([0, 0, 0.5], [1, -0.5], U[:, 1])
         + 0.1 * rng.standard_normal(400))
    m = ARX(1, [1, 1], [1, 2]).fit(y, U)
    fr = m.freqresp(np.array([0.5, 1.0]))
    assert fr.response.shape == fr.magnitude_sd.shape == (1, 2, 2)
    z = np.exp(-1j * 0.5)
    A = 1 + m.A[1] * z
    np.testing.assert_allclose(fr.response[0, 1, 0], m.B[1] @ z ** np.arange(m.B.shape[1]) / A)
    assert fr.to_frame().shape[0] == 4


@pytest.mark.parametrize("structure", ["arx", "oe"])
def test_band_coverage_monte_carlo(structure):
    """About 95 % of the ±1.96 sd bands of |G| cover the true |G| (200 runs, N = 300)."""
    w = np.array([0.2, 1.0, 2.5])
    z = np.exp(-1j * w)
    G_true = np.abs((z + 0.5 * z ** 2) / (1 - 0.6 * z))
    rng = np.random.default_rng(6)
    hits = np.zeros(w.size)
    runs = 200
    for _ in range(runs):
        if structure == "arx":
            y, u = _arx_data(300, rng)
            model = ARX(1, 2, 1)
        else:   # output error: white noise added to the output
            u = rng.standard_normal(300)
            y = lfilter([0.0, 1.0, 0.5], [1.0, -0.6], u) + 0.3 * rng.standard_normal(300)
            model = OE(2, 1, 1)
        fr = model.fit(y, u).freqresp(w)
        hits += np.abs(fr.magnitude - G_true) <= 1.96 * fr.magnitude_sd
    cover = hits / runs
    assert np.all((cover > 0.85) & (cover < 0.99)), cover


def test_rsample():
    rng = np.random.default_rng(7)
    y, u = _arx_data(400, rng)
    m = ARX(1, 2, 1).fit(y, u)
    ms = m.rsample(2000, seed=3)
    assert len(ms) == 2000 and all(type(s) is ARX for s in ms)
    th = np.array([s.theta for s in ms])
    assert np.all(np.abs(th.mean(0) - m.theta) < 4 * np.sqrt(np.diag(m.cov) / 2000))
    sd = np.sqrt(np.diag(m.cov))
    assert np.all(np.abs(np.cov(th.T) - m.cov) < 4 * np.outer(sd, sd) * np.sqrt(2 / 2000))
    assert m.theta is not ms[0].theta and ms[0].dt == m.dt
    np.testing.assert_allclose(m.rsample(1, seed=3)[0].theta, ms[0].theta)
    with pytest.raises(ValueError, match="n"):
        m.rsample(0)


# ---------------------------------------------------------------------- spa
def _spa_reference(y, u, M, w):
    N = y.size

    def R(a, b):   # biased cross-covariance, lags -M..M: (1/N) Σ a_{t+τ} b_t
        full = np.correlate(a, b, "full") / N
        return full[N - 1 - M: N + M]

    tau = np.arange(-M, M + 1)
    W = 0.5 * (1 + np.cos(np.pi * tau / M))
    E = np.exp(-1j * np.outer(w, tau))
    pu = (E @ (W * R(u, u))).real
    py = (E @ (W * R(y, y))).real
    pyu = E @ (W * R(y, u))
    return pyu / pu, py - np.abs(pyu) ** 2 / pu, pu


def test_spa_matches_explicit_formula():
    rng = np.random.default_rng(8)
    y, u = _arx_data(700, rng)
    fr = spa((y, u))
    G, pv, pu = _spa_reference(y, u, 30, np.arange(1, 129) / 128 * np.pi)
    np.testing.assert_allclose(fr.response, G, rtol=1e-12)
    np.testing.assert_allclose(fr.noise_spectrum, pv, rtol=1e-10)
    tau = np.arange(-30, 31)
    alpha = np.sum((0.5 * (1 + np.cos(np.pi * tau / 30))) ** 2)
    np.testing.assert_allclose(fr.magnitude_sd, np.sqrt(alpha / 700 * pv / pu / 2), rtol=1e-10)
    # a given window and grid, and an IDData with its dt
    w = np.array([0.5, 1.0, 4.0])
    data = IDData(y, u, dt=0.2)
    fr2 = spa(data, window=12, w=w)
    np.testing.assert_allclose(fr2.response, _spa_reference(y, u, 12, w * 0.2)[0], rtol=1e-12)
    assert fr2.dt == 0.2


def test_spa_white_noise_through_fir_near_truth():
    rng = np.random.default_rng(9)
    N = 20000
    u = rng.standard_normal(N)
    g = np.array([0.0, 1.0, 0.6, -0.3])
    y = lfilter(g, [1.0], u) + 0.1 * rng.standard_normal(N)
    fr = spa((y, u), window=30)
    G_true = np.exp(-1j * np.outer(fr.w, np.arange(4))) @ g
    assert np.max(np.abs(fr.response - G_true)) < 0.05
    assert np.all(np.abs(fr.magnitude - np.abs(G_true)) < 5 * fr.magnitude_sd + 0.02)
    # Φ_v = 0.01 (white); the lag window's bias leaks |G|² into it at M = 30, not at M = 200
    assert 0.005 < np.median(fr.noise_spectrum) < 0.05
    np.testing.assert_allclose(np.median(spa((y, u), window=200).noise_spectrum), 0.01, rtol=0.1)


def test_spa_errors():
    with pytest.raises(ValueError, match="window"):
        spa((np.ones(50), np.ones(50)), window=50)
    with pytest.raises(ValueError, match="u"):
        spa((np.ones(50), np.ones(49)))


# --------------------------------------------------------------------- etfe
def test_etfe_exact_on_periodic_multisine():
    P, periods = 64, 5
    N = P * periods
    t = np.arange(N)
    ks = [1, 3, 7, 12, 20]       # harmonics of the period
    rng = np.random.default_rng(10)
    u = sum(np.cos(2 * np.pi * k * t / P + rng.uniform(0, 2 * np.pi)) for k in ks)
    b, a = [0.0, 0.5, 0.25], [1.0, -0.8, 0.2]
    # steady state: simulate many periods, keep the last ones
    y = lfilter(b, a, np.tile(u[:P], 40))[-N:]
    fr = etfe((y, u))
    w_exc = 2 * np.pi * np.array(ks) / P
    idx = np.searchsorted(fr.w, w_exc - 1e-12)
    np.testing.assert_allclose(fr.w[idx], w_exc, rtol=1e-14)
    z = np.exp(-1j * w_exc)
    G_true = (b[1] * z + b[2] * z ** 2) / (1 + a[1] * z + a[2] * z ** 2)
    np.testing.assert_allclose(fr.response[idx], G_true, rtol=1e-10, atol=1e-12)
    others = np.setdiff1d(np.arange(fr.w.size), idx)
    assert np.all(np.isnan(fr.response[others]))


def test_etfe_smoothed_reduces_to_ratio_of_averages():
    rng = np.random.default_rng(11)
    y, u = _arx_data(256, rng)
    fr = etfe(IDData(y, u, dt=2.0), smoothing=3)
    Y, U = np.fft.fft(y), np.fft.fft(u)
    h = 0.5 * (1 + np.cos(np.pi * np.arange(-3, 4) / 4))
    k = 10
    idx = (k + np.arange(-3, 4)) % 256
    G = np.sum(h * Y[idx] * np.conj(U[idx])) / np.sum(h * np.abs(U[idx]) ** 2)
    np.testing.assert_allclose(fr.response[k - 1], G, rtol=1e-12)
    np.testing.assert_allclose(fr.w[k - 1], 2 * np.pi * k / (256 * 2.0))
    assert fr.noise_spectrum.shape == fr.w.shape and np.all(fr.noise_spectrum >= 0)


# ---------------------------------------------------------- results object
def test_frequency_response_object():
    w = np.array([0.1, 1.0, 2.0])
    G = np.exp(-1j * np.array([3.0, 6.0, 9.0]))
    fr = FrequencyResponse(w, G, 0.5, magnitude_sd=[0.1, 0.1, 0.1], phase_sd=[0.1, 0.2, 0.3])
    np.testing.assert_allclose(fr.phase, [-3.0, -6.0, -9.0])   # unwrapped
    np.testing.assert_allclose(fr.magnitude, 1.0)
    df = fr.to_frame()
    assert list(df.columns) == ["w", "magnitude", "phase", "magnitude_sd", "phase_sd"]
    assert "1 output(s)" in fr.summary() and "FrequencyResponse" in repr(fr)
    with pytest.raises(ValueError, match="response"):
        FrequencyResponse(w, np.ones(4))
    with pytest.raises(ValueError, match="w"):
        FrequencyResponse(w[::-1], G)
    with pytest.raises(ValueError, match="magnitude_sd"):
        FrequencyResponse(w, G, magnitude_sd=[1.0])


def test_plot_bode_with_bands():
    pytest.importorskip("matplotlib")
    from matplotlib.figure import Figure

    rng = np.random.default_rng(12)
    y, u = _arx_data(300, rng)
    fr = ARX(1, 2, 1, dt=0.01).fit(y, u).freqresp()
    fig = fr.plot(sd=3)
    assert isinstance(fig, Figure)
    am, ap = fig.axes[:2]
    assert am.get_ylabel() == "magnitude (dB)" and ap.get_ylabel() == "phase (deg)"
    assert ap.get_xlabel() == "frequency (rad/s)"
    assert len(am.collections) == 1 and len(ap.collections) == 1   # the two bands
    assert [t.get_text() for t in fig.legends[0].get_texts()] == ["response", "±3 sd"]
    assert fr.plot(hz=True).axes[1].get_xlabel() == "frequency (Hz)"
    assert len(spa((y, u)).plot(sd=0).axes[0].collections) == 0

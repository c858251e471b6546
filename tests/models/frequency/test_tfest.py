"""Transfer-function estimation (issue 36, point 3): tfest and TransferFunctionModel."""

import numpy as np
import pytest
from scipy.signal import lfilter

from adaptid.models import FrequencyResponse, IDData, TransferFunctionModel, tfest

control = pytest.importorskip("control")


def _cfr(num, den, w, delay=0.0):
    """G(iω) of a continuous system by python-control, with an optional delay factor."""
    H = control.frequency_response(control.tf(num, den), w).complex
    return np.squeeze(H) * np.exp(-1j * w * delay)


W = np.logspace(-2, 2, 120)


@pytest.mark.parametrize("num, den", [([1.0, 2.0], [1.0, 3.0, 5.0]),
                                      ([2.0, 1.0], [1.0, 0.4, 4.0, 1.0])])
def test_continuous_exact_recovery(num, den):
    m = tfest(FrequencyResponse(W, _cfr(num, den, W)), len(den) - 1, len(num) - 1)
    assert isinstance(m, TransferFunctionModel) and m.dt is None
    np.testing.assert_allclose(m.num, num, rtol=0, atol=1e-8)
    np.testing.assert_allclose(m.den, den, rtol=0, atol=1e-8)
    assert np.all(m.stderr < 1e-8)


def test_continuous_cancelling_pair():
    # (s + 2)/(s² + 3s + 2) = 1/(s + 1): the coefficients with np = 2 are not
    # unique, the response is; with np = 1 the reduced system is recovered
    H = _cfr([1, 2], [1, 3, 2], W)
    m2 = tfest(FrequencyResponse(W, H), 2)
    np.testing.assert_allclose(m2.freqresp(W).response, H, rtol=1e-8, atol=0)
    m1 = tfest(FrequencyResponse(W, H), 1)
    np.testing.assert_allclose(m1.num, [1.0], atol=1e-8)
    np.testing.assert_allclose(m1.den, [1.0, 1.0], atol=1e-8)


def test_continuous_with_delay():
    H = _cfr([1.0, 2.0], [1.0, 3.0, 5.0], W, delay=0.3)
    m = tfest(FrequencyResponse(W, H), 2, delay=0.3)
    np.testing.assert_allclose(m.num, [1.0, 2.0], atol=1e-8)
    np.testing.assert_allclose(m.den, [1.0, 3.0, 5.0], atol=1e-8)
    np.testing.assert_allclose(m.freqresp(W).response, H, rtol=1e-8)
    with pytest.raises(ValueError, match="pade_order"):
        m.to_control()
    sys = m.to_control(pade_order=6)
    assert sys.den[0][0].size == 3 + 6


def test_continuous_feedthrough():
    H = _cfr([0.5, 1.0, 2.0], [1.0, 3.0, 5.0], W)
    with pytest.raises(ValueError, match="nz"):
        tfest(FrequencyResponse(W, H), 2, 2)
    m = tfest(FrequencyResponse(W, H), 2, 2, feedthrough=True)
    np.testing.assert_allclose(m.num, [0.5, 1.0, 2.0], atol=1e-8)


@pytest.mark.parametrize("delay, feedthrough", [(0, False), (2, False), (1, True)])
def test_discrete_exact_recovery(delay, feedthrough):
    dt = 0.1
    nk = delay + (0 if feedthrough else 1)
    b, a = [0.5, 0.2], [1.0, -1.2, 0.5]
    B = np.concatenate([np.zeros(nk), b])
    L = max(B.size, len(a))
    sysd = control.tf(np.pad(B, (0, L - B.size)), np.pad(a, (0, L - len(a))), dt)
    w = np.linspace(0.05, np.pi / dt, 90)
    H = np.squeeze(control.frequency_response(sysd, w).complex)
    m = tfest(FrequencyResponse(w, H, dt), 2, 1, delay=delay, feedthrough=feedthrough)
    np.testing.assert_allclose(m.num, B, atol=1e-8)
    np.testing.assert_allclose(m.den, a, atol=1e-8)
    # against python-control's response of the true system, on another grid
    w2 = np.linspace(0.3, 30.0, 50)
    ref = np.squeeze(control.frequency_response(sysd, w2).complex)
    np.testing.assert_allclose(m.freqresp(w2).response, ref, rtol=1e-8)
    np.testing.assert_allclose(
        np.squeeze(control.frequency_response(m.to_control(), w2).complex), ref, rtol=1e-8)


def test_discrete_from_continuous_response_with_dt():
    # dt given explicitly overrides the response's (None) sample time
    dt = 0.5
    w = np.linspace(0.05, np.pi / dt, 60)
    z1 = np.exp(-1j * w * dt)
    H = 0.3 * z1 / (1 - 0.7 * z1)
    m = tfest(FrequencyResponse(w, H), 1, 0, dt=dt)
    np.testing.assert_allclose(m.num, [0.0, 0.3], atol=1e-8)
    np.testing.assert_allclose(m.den, [1.0, -0.7], atol=1e-8)


def test_time_data_exact_recovery():
    rng = np.random.default_rng(1)
    u = rng.standard_normal(500)
    y = lfilter([0.0, 0.0, 0.5, 0.2], [1.0, -1.2, 0.5], u)
    m = tfest(IDData(y, u, 0.1, y_names="out", u_names="in"), 2, 1, delay=1)
    np.testing.assert_allclose(m.num, [0.0, 0.0, 0.5, 0.2], atol=1e-8)
    np.testing.assert_allclose(m.den, [1.0, -1.2, 0.5], atol=1e-8)
    assert m.dt == 0.1 and m.delay == 1
    fr = m.freqresp()
    assert fr.y_names == ("out",) and fr.u_names == ("in",)
    with pytest.raises(ValueError, match="dt"):
        tfest(IDData(y, u, 0.1), 2, dt=0.2)


def test_covariance_monte_carlo():
    # noisy frequency data: the parameter sd from the final Jacobian matches the spread
    rng = np.random.default_rng(3)
    H0 = _cfr([1.0, 2.0], [1.0, 3.0, 5.0], W)
    est, sds = [], []
    for _ in range(300):
        noise = 0.01 * (rng.standard_normal(W.size) + 1j * rng.standard_normal(W.size))
        m = tfest(FrequencyResponse(W, H0 + noise), 2)
        est.append(m.theta)
        sds.append(m.stderr)
    # 300 replications: sample sd within ~5 % (1 sd); 20 % is a loose band
    np.testing.assert_allclose(np.std(est, axis=0), np.mean(sds, axis=0), rtol=0.2)


def test_results_and_errors():
    m = tfest(FrequencyResponse(W, _cfr([1.0, 2.0], [1.0, 3.0, 5.0], W)), 2)
    assert "2 pole(s), 1 zero(s)" in m.summary()
    df = m.to_frame()
    assert list(df.columns) == ["value", "stderr"] and len(df) == 4
    np.testing.assert_allclose(np.sort_complex(m.poles()),
                               np.sort_complex(np.roots([1.0, 3.0, 5.0])), atol=1e-8)
    np.testing.assert_allclose(m.zeros(), [-2.0], atol=1e-8)
    fr = m.freqresp()
    assert fr.w.size == 200 and fr.magnitude_sd is not None
    with pytest.raises(ValueError, match="np"):
        tfest(FrequencyResponse(W, _cfr([1.0], [1.0, 1.0], W)), 0)
    with pytest.raises(TypeError, match="data"):
        tfest(np.ones(3), 1)
    with pytest.raises(ValueError, match="data"):
        tfest(FrequencyResponse(W[:2], np.ones(2)), 3)
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    fig = m.plot()
    assert fig.axes[0].get_ylabel() == "magnitude (dB)"


def test_etfe_then_tfest_and_time_data_agree_with_truth():
    from adaptid.models import etfe

    rng = np.random.default_rng(4)
    u = rng.standard_normal(4000)
    y = lfilter([0.0, 0.5, 0.2], [1.0, -1.2, 0.5], u) + 0.05 * rng.standard_normal(4000)
    data = IDData(y, u, 0.1)
    truth = np.array([0.5, 0.2, -1.2, 0.5])
    for m in (tfest(etfe(data), 2, 1), tfest(data, 2, 1)):
        assert m.dt == 0.1
        # within 5 sd of the truth (first-order sd from the final Jacobian)
        assert np.all(np.abs(m.theta - truth) < 5 * m.stderr)


def test_weights():
    H0 = _cfr([1.0, 2.0], [1.0, 3.0, 5.0], W)
    wk = 1.0 / (1.0 + W)
    m = tfest(FrequencyResponse(W, H0), 2, weights=wk)      # noise-free: still exact
    np.testing.assert_allclose(m.den, [1.0, 3.0, 5.0], atol=1e-8)
    # weights = 1/sd: the weighted residuals are white, the sd matches the spread
    rng = np.random.default_rng(5)
    sd = 0.002 + 0.02 * np.abs(H0)
    est, ses = [], []
    for _ in range(200):
        H = H0 + sd * (rng.standard_normal(W.size) + 1j * rng.standard_normal(W.size))
        m = tfest(FrequencyResponse(W, H), 2, weights=1.0 / sd)
        est.append(m.theta)
        ses.append(m.stderr)
    np.testing.assert_allclose(np.std(est, axis=0), np.mean(ses, axis=0), rtol=0.25)
    with pytest.raises(ValueError, match="weights"):
        tfest(FrequencyResponse(W, H0), 2, weights=-wk)

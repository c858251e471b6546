"""compare with a measured frequency response (issue 36): fit and Bode overlay."""

import numpy as np
import pytest
from scipy.signal import lfilter

from adaptid.models import (ARX, OE, FrequencyCompareResult, FrequencyResponse, IDData,
                            StateSpaceModel, compare, spa, tfest)


def _data(N=4000, seed=0, dt=0.1):
    rng = np.random.default_rng(seed)
    u = rng.standard_normal(N)
    y = lfilter([0, 1.0, 0.5], [1, -0.6], u) + 0.1 * rng.standard_normal(N)
    return IDData(y, u, dt=dt)


def test_fit_is_the_nrmse_of_the_complex_response():
    data = _data()
    measured = spa(data)
    arx, oe = ARX(1, 2, 1).fit(data), OE(1, 1, 1).fit(data)
    res = compare(measured, arx, oe, names=["arx", "oe"])
    assert isinstance(res, FrequencyCompareResult) and res.names == ("arx", "oe")
    for fit, model in zip(res.fit, (arx, oe)):
        G, Gm = measured.response, model.freqresp(measured.w).response
        ref = 100 * (1 - np.linalg.norm(G - Gm) / np.linalg.norm(G - G.mean()))
        assert fit == pytest.approx(ref, rel=1e-12)
    assert res.fit[0] > 90 and res.fit[0] > res.fit[1]     # OE(1,1,1) lacks the b2 term
    # the true system's response fits its own response exactly
    zi = np.exp(-1j * measured.w * 0.1)
    exact = FrequencyResponse(measured.w, (zi + 0.5 * zi ** 2) / (1 - 0.6 * zi), 0.1)
    assert compare(exact, arx).fit[0] > 99
    assert "arx" in res.summary() and len(res.to_frame()) == 2


def test_state_space_mimo_and_nan_frequencies():
    A, B = np.diag([0.5, 0.2]), np.array([[1.0, 0.5], [0.3, 1.0]])
    C = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    m = StateSpaceModel(A, B, C)
    w = np.linspace(0.1, 3.0, 20)
    G = m.to_control()(np.exp(1j * w))
    G[0, 1, 3] = np.nan                                   # not excited: left out
    res = compare(FrequencyResponse(w, G, 1.0), m)
    assert res.fit.shape == (1, 3, 2)
    np.testing.assert_allclose(res.fit, 100.0)
    assert len(res.to_frame()) == 6


def test_continuous_data_and_refusals():
    w = np.logspace(-1, 1, 30)
    G = 2.0 / (1j * w + 1.0)
    data = FrequencyResponse(w, G)
    tf = tfest(data, 1, 0)
    assert compare(data, tf).fit[0] == pytest.approx(100, abs=1e-6)
    with pytest.raises(ValueError, match=r"models\[0\]"):
        compare(data, ARX(1, 1, 1).fit(_data()))          # discrete model, continuous data
    disc = spa(_data())
    with pytest.raises(ValueError, match="k"):
        compare(disc, ARX(1, 1, 1).fit(_data()), k=1)
    with pytest.raises(ValueError, match=r"models\[0\]"):
        compare(disc, ARX(1, 1, 1, dt=1.0).fit(_data(dt=1.0)))   # another dt
    with pytest.raises(TypeError, match="models"):
        compare(disc)


def test_plot_overlays_models_on_the_data_bode():
    matplotlib = pytest.importorskip("matplotlib")
    matplotlib.use("Agg")
    data = _data()
    measured = spa(data)
    res = compare(measured, ARX(1, 2, 1).fit(data), names=["arx"])
    fig = res.plot()
    am = fig.axes[0]
    assert am.get_ylabel() == "magnitude (dB)" and am.get_xlabel() == "frequency (rad/s)"
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert labels[0] == "data" and labels[1] == "±3 sd" and labels[2].startswith("arx (fit")
    np.testing.assert_allclose(am.lines[1].get_ydata(),
                               20 * np.log10(np.abs(res.responses[0].response)))
    assert res.plot(kind="nyquist").axes[0].get_xlabel() == "Re G (y/u)"

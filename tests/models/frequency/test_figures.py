"""Figures of issue 36: Bode and Nyquist with bands (SISO and the ny × nu grid), steps."""

import numpy as np
import pytest

from adaptid.models import FrequencyResponse, StateSpaceModel

matplotlib = pytest.importorskip("matplotlib")
matplotlib.use("Agg")
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.patches import Ellipse  # noqa: E402


def _mimo(ny=3, nu=2, nw=40, dt=0.1):
    w = np.linspace(0.1, np.pi / dt, nw)
    rng = np.random.default_rng(0)
    G = rng.standard_normal((ny, nu, 1)) / (1 + 1j * w)
    sd = 0.05 * np.abs(G)
    return FrequencyResponse(w, G, dt, magnitude_sd=sd, phase_sd=0.05 * np.ones(G.shape),
                             y_names=["y1", "y2", "y3"][:ny], u_names=["p", "q"][:nu])


def test_mimo_bode_is_the_grid_of_channels_with_bands():
    fr = _mimo()
    fig = fr.plot(sd=2)
    assert isinstance(fig, Figure) and len(fig.axes) == 2 * 3 * 2
    grid = np.array(fig.axes).reshape(6, 2)
    for i, yn in enumerate(fr.y_names):
        for j, un in enumerate(fr.u_names):
            am, ap = grid[2 * i, j], grid[2 * i + 1, j]
            assert am.get_title() == f"{un} → {yn}"
            assert am.get_ylabel() == "magnitude (dB)" and ap.get_ylabel() == "phase (deg)"
            assert am.get_xlabel() == ap.get_xlabel() == "frequency (rad/s)"
            assert len(am.collections) == 1 and len(ap.collections) == 1
            np.testing.assert_allclose(am.lines[0].get_ydata(),
                                       20 * np.log10(np.abs(fr.response[i, j])))
    assert fr.plot(hz=True).axes[1].get_xlabel() == "frequency (Hz)"


def test_nyquist_with_ellipses_and_labels():
    w = np.linspace(0.05, np.pi, 64)
    G = 1 / (np.exp(1j * w) - 0.5)
    fr = FrequencyResponse(w, G, 1.0, magnitude_sd=0.1 * np.abs(G), phase_sd=0.1 * np.ones(64))
    fig = fr.plot(kind="nyquist", sd=3)
    assert isinstance(fig, Figure)
    ax = fig.axes[0]
    assert ax.get_xlabel() == "Re G (y/u)" and ax.get_ylabel() == "Im G (y/u)"
    assert ax.get_title() == "u → y" and "Nyquist" in fig._suptitle.get_text()
    np.testing.assert_allclose(ax.lines[0].get_xdata(), G.real)
    np.testing.assert_allclose(ax.lines[0].get_ydata(), G.imag)
    ells = [p for p in ax.patches if isinstance(p, Ellipse)]
    assert len(ells) == 12
    e = ells[0]            # at the first frequency: half-axes 3·σ|G| and 3·|G|σarg
    assert e.width == pytest.approx(2 * 3 * 0.1 * np.abs(G[0]))
    assert e.height == pytest.approx(2 * 3 * np.abs(G[0]) * 0.1)
    assert isinstance(fr.plot_nyquist(sd=0), Figure)
    assert not [p for p in fr.plot_nyquist(sd=0).axes[0].patches if isinstance(p, Ellipse)]
    assert len(_mimo().plot(kind="nyquist").axes) == 6
    with pytest.raises(ValueError, match="kind"):
        fr.plot(kind="nichols")


def test_state_space_step_and_bode_with_bands():
    from adaptid.models.statespace._uncertainty import n_params

    m = StateSpaceModel([[0.5, 0.3], [-0.3, 0.5]], [[1.0], [0.0]], [[1.0, 0.5]], dt=0.01,
                        cov=1e-4 * np.eye(n_params(2, 1, 1)), y_names="speed",
                        u_names="voltage")
    fig = m.step_response(20).plot(sd=3)
    ax = fig.axes[0]
    assert ax.get_xlabel() == "time (s)" and ax.get_ylabel() == "speed"
    assert ax.get_title() == "voltage → speed" and len(ax.collections) == 1
    fig = m.freqresp().plot()
    assert fig.axes[0].get_title() == "voltage → speed" and len(fig.axes[0].collections) == 1
    assert isinstance(m.plot(), Figure)     # no singular values: the step response

"""spafdr (issue 36): frequency-dependent resolution spectral analysis.

Oracles: a brute-force evaluation of the defining sums (DFT as explicit
sums over t, windows by loops) and spa (Blackman–Tukey, lag domain) at the
matching resolution 2π/M.
"""

import numpy as np
import pytest
from scipy.signal import lfilter

from adaptid.models import IDData, spa, spafdr


def _record(N, seed):
    rng = np.random.default_rng(seed)
    u = rng.standard_normal(N)
    y = lfilter([0, 1.0, 0.5], [1, -0.6], u) + lfilter([1.0], [1, -0.3],
                                                     0.5 * rng.standard_normal(N))
    return y, u


def _brute(y, u, w, R, dt):
    """The defining formula, term by term."""
    N = y.size
    t = np.arange(N)
    G, sd, pv = [], [], []
    for wj, Rj in zip(w, R):
        s_uu = s_yu = s_yy = s_w = s_w2uu = 0.0
        for k in range(N):
            xi = 2 * np.pi * k / N
            xi = xi - 2 * np.pi if xi >= np.pi else xi          # in [−π, π), as fftfreq
            d = (xi - wj * dt + np.pi) % (2 * np.pi) - np.pi     # circular distance (rad/sample)
            d /= dt
            if abs(d) >= Rj:
                continue
            W = 0.5 * (1 + np.cos(np.pi * d / Rj))
            Yk = np.sum(y * np.exp(-1j * xi * t))
            Uk = np.sum(u * np.exp(-1j * xi * t))
            s_uu += W * abs(Uk) ** 2
            s_yu += W * Yk * np.conj(Uk)
            s_yy += W * abs(Yk) ** 2
            s_w += W
            s_w2uu += W * W * abs(Uk) ** 2
        g = s_yu / s_uu
        phi_v = (s_yy - abs(s_yu) ** 2 / s_uu) / (N * s_w)
        G.append(g)
        pv.append(dt * phi_v)
        sd.append(np.sqrt(N * phi_v * s_w2uu / s_uu ** 2 / 2))
    return np.array(G), np.array(sd), np.array(pv)


def test_equals_the_defining_formula():
    y, u = _record(240, seed=1)
    dt = 0.1
    w = np.array([0.2, 1.0, 5.0, 20.0, 31.0])
    R = np.array([1.0, 1.5, 2.0, 3.0, 2.0])        # the last window wraps past π/dt
    fr = spafdr(IDData(y, u, dt=dt), w=w, resolution=R)
    G, sd, pv = _brute(y, u, w, R, dt)
    np.testing.assert_allclose(fr.response, G, rtol=1e-10)
    np.testing.assert_allclose(fr.magnitude_sd, sd, rtol=1e-10)
    np.testing.assert_allclose(fr.phase_sd, sd / np.abs(G), rtol=1e-10)
    np.testing.assert_allclose(fr.noise_spectrum, pv, rtol=1e-9)


def test_default_grid_and_resolution():
    y, u = _record(1000, seed=2)
    fr = spafdr((y, u))
    assert fr.w.size == 100
    np.testing.assert_allclose(fr.w[[0, -1]], [2 * np.pi / 1000, np.pi])
    np.testing.assert_allclose(np.diff(np.log(fr.w)), np.log(fr.w[1] / fr.w[0]))
    # the default resolution is the larger gap to a neighbour (at least 2·2π/N)
    w = fr.w
    gaps = np.diff(w)
    R = np.maximum(np.maximum(np.r_[gaps[0], gaps], np.r_[gaps, gaps[-1]]), 4 * np.pi / 1000)
    G, sd, _ = _brute(y[:200], u[:200], w[60:62], R[60:62] * 5, 1.0)
    ref = spafdr((y[:200], u[:200]), w=w[60:62], resolution=R[60:62] * 5)
    np.testing.assert_allclose(ref.response, G, rtol=1e-10)
    explicit = spafdr((y, u), w=w, resolution=R)
    np.testing.assert_allclose(fr.response, explicit.response, rtol=1e-12)


def test_matches_spa_at_equal_resolution():
    """Resolution 2π/M is spa's with lag window M: the Hann lag window's spectral
    window has its first zeros at ±2π/M and Σ W²/(Σ W)² = 0.75 M/N as spa's α_M/N.
    The two windows differ in shape (side lobes), so the estimates agree to about
    1 % on this smooth system (N = 20000, M = 30), the variances to a few %."""
    y, u = _record(20000, seed=0)
    w = np.linspace(0.05, 3.0, 12)
    a = spa((y, u), window=30, w=w)
    b = spafdr((y, u), w=w, resolution=2 * np.pi / 30)
    np.testing.assert_allclose(b.response, a.response, rtol=0.01)
    np.testing.assert_allclose(b.magnitude_sd, a.magnitude_sd, rtol=0.03)
    np.testing.assert_allclose(b.noise_spectrum, a.noise_spectrum, rtol=0.05)


def test_refuses_bad_arguments():
    y, u = _record(100, seed=3)
    with pytest.raises(ValueError, match="resolution"):
        spafdr((y, u), w=[0.5, 1.0], resolution=[0.1, -1.0])
    with pytest.raises(ValueError, match="resolution"):
        spafdr((y, u), w=[0.5, 1.0], resolution=[0.1, 0.2, 0.3])
    with pytest.raises(ValueError, match="w"):
        spafdr((y, u), w=[1.0, 0.5])
    with pytest.raises(ValueError, match="w"):
        spafdr((y, u), w=[4.0])                     # beyond π/dt
    with pytest.raises(ValueError, match="data"):
        spafdr((y[:3], u[:3]))

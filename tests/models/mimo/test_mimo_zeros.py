"""MIMO ARX transmission zeros (issue 36 for MIMO ARX): ``zeros()`` with standard deviations.

Oracles: at a transmission zero z₀ of a square model with A(z₀) regular,
det B(z₀⁻¹) = 0 (B written out here from the model's coefficient arrays);
for a non-square model each channel's zeros are the roots of that channel's
numerator of adj(A)B computed here with numpy polynomials; the standard
deviations against the spread of models drawn from the covariance
(``rsample``, Monte Carlo).
"""

import numpy as np
import pytest

from adaptid.models import ARX


def _simulate(rng, N=3000):
    u = rng.standard_normal((N, 2))
    y = np.zeros((N, 2))
    for k in range(2, N):
        y[k, 0] = 0.5 * y[k - 1, 0] + u[k - 1, 0] + 0.3 * u[k - 1, 1]
        y[k, 1] = (-0.2 * y[k - 1, 1] + 0.4 * y[k - 1, 0] + 0.5 * u[k - 1, 0] + u[k - 1, 1]
                   + 0.2 * u[k - 2, 1])
    return y + 0.05 * rng.standard_normal((N, 2)), u


@pytest.fixture(scope="module")
def model():
    y, u = _simulate(np.random.default_rng(1))
    return ARX(np.ones((2, 2), int), 2 * np.ones((2, 2), int), np.ones((2, 2), int)).fit(y, u)


def test_square_zeros_make_B_singular(model):
    z = model.zeros()
    assert z.values.size == 2
    B = model.B
    for z0 in z.values:
        Bz = sum(B[lag] * z0 ** (-lag) for lag in range(B.shape[0]))
        assert abs(np.linalg.det(Bz)) < 1e-10 * np.abs(Bz).max() ** 2


def test_zero_sd_matches_the_spread_of_drawn_models(model):
    z = model.zeros()
    draws = []
    for m in model.rsample(400, seed=3):
        r = m.zeros().values
        draws.append(r[np.argsort(r.imag)])
    draws = np.array(draws)
    ref = z.values[np.argsort(z.values.imag)]
    sd_re = np.sort(z.sd_real)
    assert np.allclose(np.sort(draws.real.std(axis=0)), sd_re, rtol=0.25)
    assert np.allclose(draws.real.mean(axis=0), ref.real, atol=3 * sd_re.max())


def test_non_square_zeros_per_channel():
    rng = np.random.default_rng(2)
    N = 2000
    u = rng.standard_normal(N)
    y = np.zeros((N, 2))
    for k in range(2, N):
        y[k, 0] = 0.6 * y[k - 1, 0] + u[k - 1] + 0.5 * u[k - 2]
        y[k, 1] = -0.3 * y[k - 1, 1] + u[k - 1] - 0.8 * u[k - 2]
    m = ARX(np.eye(2, dtype=int), 2 * np.ones((2, 1), int), np.ones((2, 1), int)).fit(y, u)
    z = m.zeros()
    assert len(z) == 2 and len(z[0]) == 1
    # diagonal A: channel i's zeros are the roots of b_i1 z + b_i2
    for i in range(2):
        b = m.B[:, i, 0]
        want = np.roots(b[1:])          # B[0] = 0 (nk = 1): b1 z + b2
        np.testing.assert_allclose(np.sort_complex(z[i][0].values), np.sort_complex(want),
                                   atol=1e-9)

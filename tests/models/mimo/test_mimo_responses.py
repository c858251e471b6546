"""Responses of the MIMO ARX model with their uncertainty (issue 36 for issue 34's
MIMO ARX): closed forms for FIR models (linear in θ), finite-difference Jacobians
otherwise, python-control's step response, the poles against det A(z)."""

import copy

import numpy as np
import pytest

from adaptid.models import ARX

from .test_mimo_arx import A_TRUE, B_TRUE, NA, NB, NK, simulate_arx


@pytest.fixture
def fir(rng):
    """B only (na = 0): y = B(q) u + e with nb = [[2, 1], [1, 3]], nk = [[1, 2], [0, 1]]."""
    N = 600
    U = rng.standard_normal((N, 2))
    B = [np.array([[0.0, 0.0], [0.5, 0.0]]), np.array([[1.0, 0.0], [0.0, 1.0]]),
         np.array([[-0.4, 0.8], [0.0, 0.3]]), np.array([[0.0, 0.0], [0.0, -0.2]])]
    Y = simulate_arx([], B, U, rng.multivariate_normal([0, 0], [[0.05, 0.02], [0.02, 0.04]], N))
    return ARX(np.zeros((2, 2), int), np.array([[2, 1], [1, 3]]), np.array([[1, 2], [0, 1]])).fit(Y, U)


@pytest.fixture
def coupled(rng):
    N = 800
    U = rng.standard_normal((N, 2))
    Y = simulate_arx(A_TRUE, B_TRUE, U, 0.1 * rng.standard_normal((N, 2)))
    return ARX(np.array(NA), np.array(NB), np.array(NK)).fit(Y, U)


def _delta_sd(G, Jr, Ji, S):
    """MATLAB's delta method, written out: var|G| and var arg G from the 2x2 covariance."""
    crr, cri, cii = Jr @ S @ Jr, Jr @ S @ Ji, Ji @ S @ Ji
    x, y = G.real, G.imag
    r2 = x * x + y * y
    # (a variance that is 0 in exact arithmetic, at ω = π, may come out -1e-20: clipped)
    return (np.sqrt(max((x * x * crr + 2 * x * y * cri + y * y * cii) / r2, 0.0)),
            np.sqrt(max((y * y * crr - 2 * x * y * cri + x * x * cii) / r2 ** 2, 0.0)))


def test_fir_frequency_response_bands_equal_the_closed_form(fir):
    """G_ij(ω) = Σ_l b_l e^{-iω(nk+l)}: (Re G, Im G) is linear in θ with the rows
    cos(ω(nk + l)) and -sin(ω(nk + l)), so the propagated covariance is exact."""
    m = fir
    w = np.linspace(0.01, np.pi, 40)
    fr = m.freqresp(w)
    assert fr.response.shape == (2, 2, 40) and fr.y_names == ("y1", "y2")
    S = m.cov
    for i in range(2):
        for j in range(2):
            idx = [p for p, n in enumerate(m.names) if n.endswith(f"_y{i + 1}_u{j + 1}")]
            lags = [int(m.nk[i, j]) + int(m.names[p][1:].split("_")[0]) for p in idx]
            for q, wk in enumerate(w):
                Jr = np.zeros(m.n_params)
                Ji = np.zeros(m.n_params)
                Jr[idx] = np.cos(wk * np.array(lags))
                Ji[idx] = -np.sin(wk * np.array(lags))
                G = (Jr + 1j * Ji) @ m.theta
                ms, ps = _delta_sd(G, Jr, Ji, S)
                assert fr.response[i, j, q] == pytest.approx(G, rel=1e-12, abs=1e-14)
                assert fr.magnitude_sd[i, j, q] == pytest.approx(ms, rel=1e-9)
                assert fr.phase_sd[i, j, q] == pytest.approx(ps, rel=1e-9, abs=1e-9)  # 0 at ω = π


def test_fir_step_response_sd_is_exact(fir):
    """s_ij(t) = Σ_{nk + l <= t} b_l: linear in θ, var = 1ᵀ Σ_sub 1."""
    m = fir
    sr = m.step_response(T=8)
    for i in range(2):
        for j in range(2):
            idx = np.array([p for p, n in enumerate(m.names) if n.endswith(f"_y{i + 1}_u{j + 1}")])
            lags = np.array([int(m.nk[i, j]) + int(m.names[p][1:].split("_")[0]) for p in idx])
            for t in range(8):
                g = np.zeros(m.n_params)
                g[idx[lags <= t]] = 1.0
                assert sr.response[i, j, t] == pytest.approx(g @ m.theta, abs=1e-13)
                assert sr.sd[i, j, t] == pytest.approx(np.sqrt(g @ m.cov @ g), rel=1e-9, abs=1e-15)


def _jacobian(m, f, h=1e-6):
    """Central differences of f(model) with respect to θ."""
    cols = []
    for p in range(m.n_params):
        lo, hi = copy.copy(m), copy.copy(m)
        lo.theta = m.theta.copy()
        hi.theta = m.theta.copy()
        lo.theta[p] -= h
        hi.theta[p] += h
        cols.append((f(hi) - f(lo)) / (2 * h))
    return np.stack(cols, axis=-1)


def test_frequency_response_sd_with_coupled_A_matches_finite_differences(coupled):
    """Non-FIR: the analytic Jacobian −A⁻¹E_ij q^{-l} G against central differences
    (the propagation couples the equations through cov's cross blocks)."""
    m = coupled
    w = np.array([0.1, 0.7, 2.0])
    fr = m.freqresp(w)
    J = _jacobian(m, lambda x: x.freqresp(w).response)
    for i in range(2):
        for j in range(2):
            for q in range(w.size):
                ms, ps = _delta_sd(fr.response[i, j, q], J[i, j, q].real, J[i, j, q].imag, m.cov)
                assert fr.magnitude_sd[i, j, q] == pytest.approx(ms, rel=1e-5)
                assert fr.phase_sd[i, j, q] == pytest.approx(ps, rel=1e-5)


def test_step_response_against_python_control_and_finite_differences(coupled):
    control = pytest.importorskip("control")
    m = coupled
    T = 30
    sr = m.step_response(T)
    assert sr.response.shape == (2, 2, T)
    ref = control.step_response(m.to_control("ss"), T=np.arange(T) * m.dt).outputs
    np.testing.assert_allclose(sr.response, ref, atol=1e-10)
    J = _jacobian(m, lambda x: x.step_response(T).response)
    sd = np.sqrt(np.einsum("outp,pq,outq->out", J, m.cov, J))
    np.testing.assert_allclose(sr.sd, sd, rtol=1e-5, atol=1e-10)


def test_poles_are_the_roots_of_det_A_with_finite_difference_sd(coupled):
    m = coupled
    A = m.A                                      # (3, 2, 2), powers of q^-1
    det = (np.convolve(A[:, 0, 0], A[:, 1, 1]) - np.convolve(A[:, 0, 1], A[:, 1, 0]))
    ref = np.roots(det)                          # z^4 det A(z^-1)
    got = m.poles().values
    np.testing.assert_allclose(np.sort_complex(got[np.abs(got) > 1e-12]),
                               np.sort_complex(ref[np.abs(ref) > 1e-12]), rtol=1e-10)
    p = m.poles()
    order = np.argsort(np.abs(p.values))[::-1][:3]   # the three non-zero poles
    J = _jacobian(m, lambda x: x.poles().values[order])
    np.testing.assert_allclose(p.sd_real[order], np.sqrt(np.einsum("rp,pq,rq->r", J.real, m.cov,
                                                                   J.real)), rtol=1e-4)


def test_rsample_draws_from_the_parameter_distribution(coupled):
    m = coupled
    models = m.rsample(4000, seed=3)
    thetas = np.array([x.theta for x in models])
    assert type(models[0]) is type(m) and models[0].names == m.names
    np.testing.assert_allclose(thetas.mean(axis=0), m.theta, atol=5 * np.sqrt(np.diag(m.cov).max() / 4000))
    np.testing.assert_allclose(np.cov(thetas.T), m.cov, atol=0.1 * np.abs(m.cov).max())
    again = m.rsample(2, seed=3)
    np.testing.assert_array_equal(again[1].theta, models[1].theta)
    with pytest.raises(ValueError, match="n"):
        m.rsample(0)


def test_monte_carlo_spread_matches_the_bands(rng):
    """Over repeated experiments with correlated innovations, the spread of |G| and
    arg G at a few frequencies matches the propagated standard deviations (first
    order, so within sampling error: 300 runs give the sd of an sd about 4 %)."""
    w = np.array([0.2, 1.0, 2.5])
    mags, phases, msd, psd = [], [], [], []
    for _ in range(300):
        U = rng.standard_normal((400, 2))
        E = rng.multivariate_normal([0, 0], [[0.04, 0.03], [0.03, 0.04]], size=400)
        m = ARX(np.array(NA), np.array(NB), np.array(NK)).fit(simulate_arx(A_TRUE, B_TRUE, U, E), U)
        fr = m.freqresp(w)
        mags.append(fr.magnitude)
        phases.append(np.angle(fr.response))
        msd.append(fr.magnitude_sd)
        psd.append(fr.phase_sd)
    ratio_m = np.std(mags, axis=0) / np.mean(msd, axis=0)
    ratio_p = np.std(phases, axis=0) / np.mean(psd, axis=0)
    assert np.all(np.abs(ratio_m - 1) < 0.2), ratio_m
    assert np.all(np.abs(ratio_p - 1) < 0.2), ratio_p

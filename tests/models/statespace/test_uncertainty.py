"""State-space responses with bands (issue 36): covariance of the full parameterisation.

References the tests use, none written with the code under test: finite
differences of ``predict`` (existing code) for the sensitivities; the
closed-form prediction-error covariance of the equivalent ARMAX structure
(filters by ``scipy.signal.lfilter``, derivatives of B/A by hand);
python-control's zeros; Monte Carlo over independent records.
"""

import numpy as np
import pytest
from scipy.signal import lfilter

from adaptid.models import FrequencyResponse, Roots, StateSpaceModel, StepResponse, n4sid
from adaptid.models.statespace._uncertainty import _sensitivities, n_params, pack, unpack

TRUE_OE = StateSpaceModel([[0.5, 0.3], [-0.3, 0.5]], [[1.0], [0.0]], [[1.0, 0.5]])


def test_sensitivities_equal_finite_differences_of_predict():
    model = StateSpaceModel([[1.5, -0.7], [1.0, 0.0]], [[1.0], [0.0]], [[1.0, 0.5]],
                            [[0.3]], [[0.5], [0.2]])
    rng = np.random.default_rng(0)
    Y, U, x0 = rng.standard_normal((60, 1)), rng.standard_normal((60, 1)), rng.standard_normal(2)
    E, J = _sensitivities(model, Y, U, x0)
    np.testing.assert_allclose(E, Y - model.predict(Y, U, x0=x0), atol=1e-13)
    th, d, h = pack(model.A, model.B, model.C, model.D, model.K), n_params(2, 1, 1), 1e-6
    for j in range(d + 2):
        if j < d:
            step = np.zeros(d)
            step[j] = h
            mp, mm = (StateSpaceModel(*unpack(th + s, 2, 1, 1)) for s in (step, -step))
            xp = xm = x0
        else:
            mp = mm = model
            xp, xm = x0.copy(), x0.copy()
            xp[j - d] += h
            xm[j - d] -= h
        fd = (mm.predict(Y, U, x0=xm) - mp.predict(Y, U, x0=xp)) / (2 * h)   # ∂ε = −∂ŷ
        # central differences: truncation ~h² and rounding ~eps/h ≈ 1e-10 relative
        np.testing.assert_allclose(J[:, :, j], fd, atol=1e-7)


def _armax_record(a, b, c, N, seed):
    rng = np.random.default_rng(seed)
    u = rng.standard_normal(N)
    e = 0.5 * rng.standard_normal(N)
    A, B, C = np.r_[1.0, a], np.r_[0.0, b], np.r_[1.0, c]
    return lfilter(B, A, u) + lfilter(C, A, e), u


def test_full_parameterisation_equals_armax_closed_form():
    """Order n with K free is ARMAX(n, n, n), nk = 1: same predictor, same cov of G."""
    a, b, c = np.array([-1.2, 0.5]), np.array([1.0, 0.4]), np.array([0.3, 0.1])
    y, u = _armax_record(a, b, c, 800, seed=3)
    # observer canonical form of A y = B u + C e
    ss = StateSpaceModel([[-a[0], 1.0], [-a[1], 0.0]], [[b[0]], [b[1]]], [[1.0, 0.0]],
                         K=[[c[0] - a[0]], [c[1] - a[1]]])
    ss.cov = ss.estimate_cov((y, u), x0="zero")
    # closed form: ε = (A y − B u)/C, ψ = ∂ε/∂[a, b, c], zero initial conditions
    A, B, C = np.r_[1.0, a], np.r_[0.0, b], np.r_[1.0, c]
    eps = lfilter(A, C, y) - lfilter(B, C, u)
    sh = lambda x, k: np.r_[np.zeros(k), x[:-k]]          # noqa: E731 - q^-k
    Psi = np.column_stack([lfilter([1.0], C, sh(y, 1)), lfilter([1.0], C, sh(y, 2)),
                           -lfilter([1.0], C, sh(u, 1)), -lfilter([1.0], C, sh(u, 2)),
                           -lfilter([1.0], C, sh(eps, 1)), -lfilter([1.0], C, sh(eps, 2))])
    S = eps @ eps / eps.size * np.linalg.inv(Psi.T @ Psi)   # the test's oracle, small and exact
    w = np.array([0.05, 0.3, 1.0, 2.0, 3.0])
    zi = np.exp(-1j * w)
    Az, Bz = 1 + a[0] * zi + a[1] * zi ** 2, b[0] * zi + b[1] * zi ** 2
    G = Bz / Az
    g = np.column_stack([-G * zi / Az, -G * zi ** 2 / Az, zi / Az, zi ** 2 / Az,
                         np.zeros_like(zi), np.zeros_like(zi)])
    dmag = (np.conj(G)[:, None] * g).real / np.abs(G)[:, None]     # ∂|G| = Re(Ḡ ∂G)/|G|
    sd_ref = np.sqrt(np.einsum("wi,ij,wj->w", dmag, S, dmag))
    fr = ss.freqresp(w)
    np.testing.assert_allclose(fr.response, G, rtol=1e-12)
    np.testing.assert_allclose(fr.magnitude_sd, sd_ref, rtol=1e-6)
    # poles: roots of z² + a1 z + a2, ∂r/∂a_j = −r^{2−j}/p'(r)
    r = np.roots(np.r_[1.0, a])
    gr = np.column_stack([-r / (2 * r + a[0]), -1 / (2 * r + a[0]), np.zeros((2, 4))])
    ref = {round(v.real, 9): np.sqrt(gi.real @ S @ gi.real) for v, gi in zip(r, gr)}
    P = ss.poles()
    for v, s in zip(P.values, P.sd_real):
        np.testing.assert_allclose(s, ref[round(v.real, 9)], rtol=1e-6)


def test_similarity_transform_leaves_the_bands_unchanged():
    rng = np.random.default_rng(4)
    u = rng.standard_normal((500, 1))
    y = TRUE_OE.simulate(u) + 0.3 * rng.standard_normal((500, 1))
    m = n4sid((y, u), 2)
    T = np.array([[2.0, 0.3], [-0.5, 1.0]])
    Ti = np.linalg.inv(T)
    m2 = StateSpaceModel(T @ m.A @ Ti, T @ m.B, m.C @ Ti, m.D, T @ m.K, dt=m.dt)
    m2.cov = m2.estimate_cov((y, u), feedthrough=False)
    a, b = m.freqresp(), m2.freqresp()
    np.testing.assert_allclose(b.response, a.response, rtol=1e-9)
    np.testing.assert_allclose(b.magnitude_sd, a.magnitude_sd, rtol=1e-5)
    np.testing.assert_allclose(b.phase_sd, a.phase_sd, rtol=1e-5)
    np.testing.assert_allclose(m2.step_response(30).sd, m.step_response(30).sd, rtol=1e-5,
                               atol=1e-12)
    # no band on D when there is no feedthrough
    assert m.info["feedthrough"] is False
    oD = 4 + 2 + 2
    assert np.all(m.cov[oD, :] == 0)


def test_bands_agree_with_rsample_spread():
    rng = np.random.default_rng(6)
    u = rng.standard_normal((800, 1))
    y = TRUE_OE.simulate(u) + 0.3 * rng.standard_normal((800, 1))
    m = n4sid((y, u), 2)
    w = np.array([0.2, 1.0, 2.5])
    draws = m.rsample(3000, seed=1)
    assert isinstance(draws[0], StateSpaceModel) and draws[0].cov is m.cov
    mags = np.array([d.freqresp(w).magnitude for d in draws])
    steps = np.array([d.step_response(15).response for d in draws])
    poles = np.array([np.sort_complex(d.poles().values) for d in draws])
    # first-order bands vs the spread of 3000 draws, measured robustly (the draws of a
    # full parameterisation have heavy tails: a linear draw can move a pole far): the
    # interquartile range / 1.349 of a normal; ~2.5 % sampling error and the curvature
    sd = lambda x: np.subtract(*np.percentile(x, [75, 25], axis=0)) / 1.349   # noqa: E731
    np.testing.assert_allclose(sd(mags), m.freqresp(w).magnitude_sd, rtol=0.1)
    np.testing.assert_allclose(sd(steps)[1:], m.step_response(15).sd[1:], rtol=0.1)
    P = m.poles()
    k = [int(np.argmin(np.abs(P.values - v))) for v in np.sort_complex(P.values)]
    np.testing.assert_allclose(sd(poles.real), P.sd_real[k], rtol=0.1)
    np.testing.assert_allclose(sd(poles.imag), P.sd_imag[k], rtol=0.1)


def test_zeros_equal_python_control_and_carry_sd():
    control = pytest.importorskip("control")
    m = StateSpaceModel([[0.5, 0.3], [-0.3, 0.5]], [[1.0], [0.2]], [[1.0, 0.5]], [[0.2]],
                        cov=np.eye(n_params(2, 1, 1)) * 1e-4)
    z = m.zeros()
    assert isinstance(z, Roots) and z.sd_real is not None
    np.testing.assert_allclose(np.sort_complex(z.values),
                               np.sort_complex(control.zeros(m.to_control())), atol=1e-10)
    mimo = StateSpaceModel(np.diag([0.5, 0.2]), np.eye(2)[:, :1], np.eye(2))
    zz = mimo.zeros()                                 # 2 outputs, 1 input: per channel
    assert len(zz) == 2 and isinstance(zz[0][0], Roots)


def test_mimo_shapes_and_tables():
    A, B = np.diag([0.5, 0.2]), np.array([[1.0, 0.0], [0.3, 1.0]])
    C = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    m = StateSpaceModel(A, B, C, cov=np.eye(n_params(2, 2, 3)) * 1e-4,
                        y_names=["a", "b", "c"], u_names=["p", "q"])
    fr = m.freqresp()
    assert isinstance(fr, FrequencyResponse)
    assert fr.response.shape == fr.magnitude_sd.shape == fr.phase_sd.shape == (3, 2, 128)
    np.testing.assert_allclose(fr.response[:, :, 5],
                               m.to_control()(np.exp(1j * fr.w[5])), rtol=1e-12)
    df = fr.to_frame()
    assert len(df) == 6 * 128 and {"output", "input", "magnitude_sd"} <= set(df.columns)
    sr = m.step_response(10)
    assert isinstance(sr, StepResponse) and sr.response.shape == sr.sd.shape == (3, 2, 10)
    np.testing.assert_allclose(sr.response[:, :, -1], np.cumsum(m.markov(10), axis=0)[-1])


def test_monte_carlo_coverage_of_n4sid_bands():
    """200 records of a 2nd-order system with white output noise (n4sid is then close
    to efficient): the true |G| lies within ±2 sd of the estimate in 95.4 % of the runs
    for a Gaussian estimate; tolerance ±5 % (3 binomial sd of a fraction over 200 runs)."""
    w = np.array([0.1, 0.5, 1.0, 2.0])
    G0 = np.abs(TRUE_OE.freqresp(w).response)
    hits = []
    for r in range(200):
        rng = np.random.default_rng(100 + r)
        u = rng.standard_normal((1000, 1))
        y = TRUE_OE.simulate(u) + 0.7 * rng.standard_normal((1000, 1))
        fr = n4sid((y, u), 2).freqresp(w)
        hits.append(np.abs(fr.magnitude - G0) <= 2 * fr.magnitude_sd)
    cover = np.mean(hits, axis=0)
    assert np.all(np.abs(cover - 0.954) <= 0.05), cover


def test_model_from_matrices_has_no_bands_and_refuses_rsample():
    m = StateSpaceModel([[0.5]], [[1.0]], [[1.0]])
    assert m.cov is None and m.freqresp().magnitude_sd is None and m.step_response().sd is None
    with pytest.raises(ValueError, match="cov"):
        m.rsample(3)
    with pytest.raises(ValueError, match="cov"):
        m.cov = np.eye(2)
    with pytest.raises(ValueError, match="x0"):
        m.estimate_cov((np.zeros(10), np.zeros(10)), x0="free")

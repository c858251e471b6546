"""Multi-input output-error models: OE with one B_i/F_i per input.

Oracles: the true system the data are simulated from; an independent
minimisation of the documented criterion (scipy least_squares with a
finite-difference Jacobian on residuals written here with numpy/scipy); a
direct information-form solve of the pseudo-linear regression; python-control
for to_control; the single-input model for m = 1.
"""

import control
import numpy as np
import pytest
from scipy import optimize
from scipy.signal import lfilter

import adaptid
from adaptid.models import OE

# y = B1/F1 u1 + B2/F2 u2 + e   (q^-1 polynomials; nk1 = 1, nk2 = 2)
B1, F1 = np.array([0.5, 0.3]), np.array([1.0, -0.7])
B2, F2 = np.array([1.0]), np.array([1.0, -1.2, 0.5])
NB, NF, NK = [2, 1], [1, 2], [1, 2]
TRUTH = np.r_[B1, B2, F1[1:], F2[1:]]


def _simulate(rng, N, sigma=0.2, colored=False):
    U = rng.standard_normal((N, 2))
    e = sigma * rng.standard_normal(N)
    if colored:
        e = lfilter([1.0, 0.8], [1.0, -0.5], e)
    y = (lfilter(np.r_[0.0, B1], F1, U[:, 0]) + lfilter(np.r_[0.0, 0.0, B2], F2, U[:, 1]) + e)
    return y, U


@pytest.fixture(scope="module")
def data():
    return _simulate(np.random.default_rng(2024), 8000)


def test_batch_and_recursive_fits_recover_the_truth(data):
    y, U = data
    m = OE(NB, NF, NK).fit(y, U, refine=False)   # Steiglitz-McBride (backfitting) alone
    assert m.names == ("b0_0", "b0_1", "b1_0", "f0_1", "f1_1", "f1_2")
    np.testing.assert_allclose(m.theta, TRUTH, atol=0.02)
    r = OE(NB, NF, NK).fit(y, U, refine=True)
    assert np.all(np.abs(r.theta - TRUTH) < 4 * r.stderr)
    assert np.max(r.stderr) < 0.01
    rec = OE(NB, NF, NK)
    traj = rec.fit_recursive(y, U)
    assert traj.theta.shape == (len(y) - 2, 6)
    np.testing.assert_allclose(rec.theta, TRUTH, atol=0.03)
    # the polynomials, per input, padded to a common length
    np.testing.assert_allclose(r.F, [[1.0, r.theta[3], 0.0], [1.0, *r.theta[4:]]])
    np.testing.assert_allclose(r.B, [[0.0, *r.theta[:2]], [0.0, 0.0, r.theta[2]]])


def test_consistent_with_coloured_noise_where_arx_is_not():
    y, U = _simulate(np.random.default_rng(7), 20000, sigma=0.3, colored=True)
    m = OE(NB, NF, NK).fit(y, U, refine=True)
    np.testing.assert_allclose(m.theta, TRUTH, atol=0.03)


def _criterion_residuals(theta, y, U):
    """The documented criterion, written independently: rows k = s..N-1,
    w_i = (1/F_i)(B_i u_i) with the B-part taken from the full record and
    the 1/F_i filter started at row s from rest."""
    s = max(nk + nb for nb, nk in zip(NB, NK)) - 1
    b1, b2 = theta[0:2], theta[2:3]
    f1, f2 = theta[3:4], theta[4:6]
    x1 = np.convolve(U[:, 0], np.r_[0.0, b1])[: len(y)]
    x2 = np.convolve(U[:, 1], np.r_[0.0, 0.0, b2])[: len(y)]
    w = lfilter([1.0], np.r_[1.0, f1], x1[s:]) + lfilter([1.0], np.r_[1.0, f2], x2[s:])
    return y[s:] - w


def test_refinement_reaches_the_independent_minimiser(data):
    y, U = data[0][:3000], data[1][:3000]
    start = OE(NB, NF, NK).fit(y, U, refine=False).theta
    ours = OE(NB, NF, NK).fit(y, U, refine=True)
    ref = optimize.least_squares(_criterion_residuals, start, args=(y, U), method="lm",
                                 xtol=1e-14, ftol=1e-14, gtol=1e-14)
    np.testing.assert_allclose(ours.theta, ref.x, rtol=1e-6, atol=1e-8)
    np.testing.assert_allclose(ours.residuals, _criterion_residuals(ref.x, y, U), atol=1e-7)


def _naive_plr(y, U, lam, P0):
    """Direct (information-form) solve of the multi-input pseudo-linear
    regression: at every k, θ_k = argmin of the forgotten cost over the rows
    so far, the rows holding the a-posteriori simulated outputs w_i."""
    s = max(nk + nb for nb, nk in zip(NB, NK)) - 1
    N = len(y) - s
    rows = np.zeros((N, 6))
    Th = np.zeros((N, 6))
    w1 = np.zeros(N)
    w2 = np.zeros(N)
    for r in range(N):
        k = r + s
        lag = lambda w, j: w[r - j] if r - j >= 0 else 0.0  # noqa: E731
        rows[r] = [U[k - 1, 0], U[k - 2, 0], U[k - 2, 1], -lag(w1, 1), -lag(w2, 1), -lag(w2, 2)]
        wts = lam ** (r - np.arange(r + 1))
        R = (rows[: r + 1] * wts[:, None]).T @ rows[: r + 1] + lam ** (r + 1) * np.eye(6) / P0
        Th[r] = np.linalg.solve(R, (rows[: r + 1] * wts[:, None]).T @ y[s: k + 1])
        w1[r] = rows[r, [0, 1, 3]] @ Th[r, [0, 1, 3]]
        w2[r] = rows[r, [2, 4, 5]] @ Th[r, [2, 4, 5]]
    return Th


@pytest.mark.parametrize("lam", [1.0, 0.99])
def test_recursive_fit_equals_the_direct_solve(data, lam):
    y, U = data[0][:400], data[1][:400]
    traj = OE(NB, NF, NK).fit_recursive(y, U, adaptid.RLS(6, forgetting=lam, P0=100.0))
    np.testing.assert_allclose(traj.theta, _naive_plr(y, U, lam, 100.0), rtol=1e-7, atol=1e-9)


@pytest.mark.parametrize("form", ["tf", "ss"])
def test_to_control_forced_response_equals_simulate(data, rng, form):
    y, U = data
    m = OE(NB, NF, NK, dt=0.01).fit(y[:2000], U[:2000])
    uu = rng.standard_normal((2, 300))
    sys, T = m.to_control(form), np.arange(300) * 0.01
    if form == "ss":
        out = np.squeeze(control.forced_response(sys, T=T, U=uu).outputs)
    else:  # a MIMO tf needs slycot to simulate: one SISO channel per input
        out = sum(np.squeeze(control.forced_response(sys[0, i], T=T, U=uu[i]).outputs)
                  for i in range(2))
    np.testing.assert_allclose(out, m.simulate(uu.T), rtol=1e-9, atol=1e-10)
    np.testing.assert_allclose(m.predict(y[:300], uu.T), m.simulate(uu.T), atol=1e-12)


def test_one_input_as_a_column_or_a_list_is_the_single_input_model(data):
    y, U = data
    u = U[:, 0]
    a = OE(2, 1, 1).fit(y[:2000], u[:2000], refine=True)
    b = OE([2], [1], [1]).fit(y[:2000], u[:2000, None], refine=True)
    np.testing.assert_array_equal(a.theta, b.theta)
    assert a.names == ("b0", "b1", "f1") and b.names == ("b0_0", "b0_1", "f0_1")
    ta = OE(2, 1, 1).fit_recursive(y[:500], u[:500])
    tb = OE([2], [1], [1]).fit_recursive(y[:500], u[:500, None])
    np.testing.assert_array_equal(ta.theta, tb.theta)


def test_static_input_and_bad_orders(data):
    y, U = data
    m = OE([2, 1], [1, 0], [1, 2]).fit(y[:1000], U[:1000])  # nf = 0: input 2 as FIR
    assert m.theta.size == 4 and m.F.shape == (2, 2)
    np.testing.assert_allclose(m.F[1], [1.0, 0.0])
    with pytest.raises(ValueError, match=r"nk must be an integer or a sequence of 2"):
        OE([2, 1], 1, [1, 2, 3]).fit(y, U)
    with pytest.raises(ValueError, match=r"nf\[0\] must be an integer >= 0"):
        OE(1, [-1, 1])
    with pytest.raises(ValueError, match="u must be with 2 input column"):
        OE(NB, NF, NK).fit(y, U).simulate(U[:, :1])

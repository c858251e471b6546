"""NARX's compiled free run and predictor against plain Python loops (issue 35)."""

import numpy as np
import pytest

from adaptid import IDData
from adaptid.models import NARX


def system(N=500, seed=0, noise=0.02):
    """Two inputs, cubic terms and a constant."""
    rng = np.random.default_rng(seed)
    u = rng.uniform(-1, 1, (N, 2))
    y = np.zeros(N)
    y[:3] = 0.3
    for k in range(3, N):
        y[k] = (0.1 + 0.5 * y[k - 1] - 0.2 * y[k - 2] + 0.8 * u[k - 1, 0]
                - 0.3 * u[k - 2, 0] * y[k - 1] + 0.1 * u[k - 1, 1] ** 2 * y[k - 2]
                + noise * rng.standard_normal())
    return y, u


def naive_free_run(m, y0, u):
    """The free run written out: Python floats, each term's product left to right and
    the sum over the terms in order (the kernel's documented order)."""
    yb, ub = m._base_layout()
    N, L = u.shape[0], m.max_lag
    Y = np.zeros((N, m._p))
    Y[:L] = np.reshape(y0, (N, -1))[:L]
    for k in range(L, N):
        x = [1.0] + [float(Y[k - j, i]) for i, j in yb] + [float(u[k - j, i]) for i, j in ub]
        for o, r in enumerate(m.results):
            s = 0.0
            for th, combo in zip(r.theta[: r.n_process], r.combos):
                p = x[combo[0]]
                for c in combo[1:]:
                    p = p * x[c]
                s = s + float(th) * p
            Y[k, o] = s
    return Y


def test_simulate_is_the_naive_loop_bit_for_bit():
    y, u = system()
    m = NARX(2, 2, 3, n_terms=8).fit(y, u)
    sim = m.simulate(u, y0=y)
    np.testing.assert_array_equal(sim, naive_free_run(m, y, u)[:, 0])
    assert np.std(sim[3:] - y[3:]) < 0.1  # and it follows the record


def test_simulate_mimo_bit_for_bit_and_from_zeros():
    rng = np.random.default_rng(4)
    N = 300
    u = rng.uniform(-1, 1, N)
    y = np.zeros((N, 2))
    for k in range(1, N):
        y[k, 0] = 0.5 * y[k - 1, 0] + u[k - 1] + 0.2 * y[k - 1, 1] * u[k - 1]
        y[k, 1] = 0.3 * y[k - 1, 1] - 0.4 * y[k - 1, 0] ** 2 + 0.1
    m = NARX(1, 1, 2).fit(IDData(y, u))
    np.testing.assert_array_equal(m.simulate(u, y0=y), naive_free_run(m, y, u[:, None]))
    np.testing.assert_array_equal(m.simulate(u), naive_free_run(m, np.zeros((N, 2)),
                                                                u[:, None]))


def test_one_step_predict_is_the_naive_sum_bit_for_bit():
    y, u = system(seed=3)
    m = NARX(2, 2, 3, n_terms=8).fit(y, u)
    yb, ub = m._base_layout()
    want = y.copy()
    for k in range(m.max_lag, y.size):
        x = [1.0] + [float(y[k - j]) for _, j in yb] + [float(u[k - j, i]) for i, j in ub]
        s = 0.0
        for th, combo in zip(m.theta, m.result.combos):
            p = x[combo[0]]
            for c in combo[1:]:
                p = p * x[c]
            s = s + float(th) * p
        want[k] = s
    np.testing.assert_array_equal(m.predict(y, u), want)
    # the fit's residuals are the same one-step errors (to rounding: lstsq's own product)
    np.testing.assert_allclose(y[2:] - want[2:], m.residuals, atol=1e-12)


def test_time_series_simulation_takes_the_number_of_samples():
    N = 200
    y = np.zeros(N)
    y[0] = 0.3
    for k in range(1, N):
        y[k] = 3.7 * y[k - 1] * (1 - y[k - 1])
    m = NARX(1, 0, 2).fit(y)
    sim = m.simulate(N, y0=y)
    np.testing.assert_array_equal(sim, naive_free_run(m, y, np.zeros((N, 0)))[:, 0])
    with pytest.raises(ValueError, match="u"):
        m.simulate(0)


def test_max_memory_blocks_give_the_same_fit_in_bounded_memory():
    """max_memory: the prefix products in row blocks; the N × M candidate matrix (here
    73 MiB) is never formed, and the fit's peak allocation follows the budget."""
    import tracemalloc

    rng = np.random.default_rng(7)
    N = 20_000
    u = rng.uniform(-1, 1, (N, 2))
    y = np.zeros(N)
    for k in range(2, N):
        y[k] = (0.5 * y[k - 1] + 0.8 * u[k - 1, 0] - 0.3 * u[k - 2, 1] * y[k - 1]
                + 0.02 * rng.standard_normal())
    full = NARX(4, 4, 3, n_terms=6).fit(y, u)
    assert full.result.n_candidates == 455          # C(15, 3); Q alone is 91 columns
    tracemalloc.start()
    try:
        small = NARX(4, 4, 3, n_terms=6, max_memory=2**20).fit(y, u)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert small.terms == full.terms
    np.testing.assert_allclose(small.theta, full.theta, rtol=1e-10)
    np.testing.assert_allclose(small.err, full.err, rtol=1e-10)
    q_bytes = N * 91 * 8                              # the prefix products kept whole
    assert peak < 0.75 * q_bytes, peak / 2**20
    with pytest.raises(ValueError, match="max_memory"):
        NARX(1, 1, max_memory=0)

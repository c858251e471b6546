"""FastRLS (issue 38): the O(n) delay-line RLS against what it must equal.

References not written with FastRLS: adaptid.RLS (the O(n²) U-D recursion) on
the tapped-delay regressors with the soft-start prior P0 = diag(λ^i)/δ, and
the closed-form exponentially weighted least-squares solution (NumPy lstsq
on weighted rows plus the prior's rows).
"""

import pickle

import numpy as np
import pytest

import adaptid
from adaptid import FastRLS, RLS, StateFileError

METHODS = ["ftf", "lattice"]


def delay_rows(u, n):
    """Prewindowed tapped delay line: row k = [u_k, ..., u_(k-n+1)], zeros before u_0."""
    N = u.shape[0]
    Phi = np.zeros((N, n))
    for i in range(n):
        Phi[i:, i] = u[: N - i]
    return Phi


def record(rng, n, N, noise=0.1):
    u = rng.standard_normal(N)
    h = rng.standard_normal(n)
    return u, np.convolve(u, h)[:N] + noise * rng.standard_normal(N), h


def rel(a, b):
    return np.max(np.abs(a - b)) / np.max(np.abs(b))


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("lam", [1.0, 0.999, 0.98])
@pytest.mark.parametrize("n", [1, 2, 5, 16])
def test_equals_rls_with_soft_start_prior(method, lam, n):
    rng = np.random.default_rng(100 * n + int(1000 * lam))
    delta = 0.05
    u, y, _ = record(rng, n, 600)
    fast = FastRLS(n, forgetting=lam, delta=delta, method=method).run_fir(u, y)
    ref = RLS(n, forgetting=lam, P0=np.diag(lam ** np.arange(n)) / delta).run(delay_rows(u, n), y)
    # both are rounding-level recursions of the same least-squares problem; 600
    # samples of a well-conditioned record keep both within ~1e-13 (1e-9 leaves room
    # for the CPU's FMA contraction and summation order)
    assert rel(fast.error, ref.error) < 1e-9
    assert rel(fast.theta, ref.theta) < 1e-9


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("lam", [1.0, 0.99])
def test_closed_form_weighted_least_squares_at_checkpoints(method, lam):
    rng = np.random.default_rng(7)
    n, N, delta = 6, 400, 0.3
    u, y, _ = record(rng, n, N, noise=0.5)
    traj = FastRLS(n, forgetting=lam, delta=delta, method=method).run_fir(u, y)
    Phi = delay_rows(u, n)
    for N1 in (1, 3, 10, 57, 400):
        # minimise Σ λ^(N1-k) (y_k - φ_kᵀθ)² + δ Σ_i λ^(N1-i) θ_i²  (k, i from 1 and 0)
        w = np.sqrt(lam ** (N1 - 1 - np.arange(N1)))
        prior = np.diag(np.sqrt(delta * lam ** (N1 - np.arange(n))))
        A = np.vstack([w[:, None] * Phi[:N1], prior])
        b = np.concatenate([w * y[:N1], np.zeros(n)])
        theta = np.linalg.lstsq(A, b, rcond=None)[0]
        np.testing.assert_allclose(traj.theta[N1 - 1], theta, rtol=1e-9, atol=1e-11)


@pytest.mark.parametrize("method", METHODS)
def test_prior_mean_theta0_as_rls(method):
    rng = np.random.default_rng(3)
    n, lam, delta = 4, 0.995, 1.0
    u, y, _ = record(rng, n, 200)
    th0 = np.array([0.3, -1.0, 2.0, 0.5])
    fast = FastRLS(n, forgetting=lam, delta=delta, theta0=th0, method=method).run_fir(u, y)
    ref = RLS(n, forgetting=lam, theta0=th0,
              P0=np.diag(lam ** np.arange(n)) / delta).run(delay_rows(u, n), y)
    assert rel(fast.theta, ref.theta) < 1e-10
    assert rel(fast.error, ref.error) < 1e-10


@pytest.mark.parametrize("method", METHODS)
def test_update_run_run_fir_chunks_and_batched_agree_bit_for_bit(method):
    rng = np.random.default_rng(5)
    n, N = 5, 120
    u, y, _ = record(rng, n, N)
    Phi = delay_rows(u, n)
    kw = dict(forgetting=0.99, delta=0.1, method=method)
    whole = FastRLS(n, **kw).run_fir(u, y)
    est = FastRLS(n, **kw)
    errs = [est.update(Phi[k], y[k]) for k in range(N)]
    assert np.array_equal(errs, whole.error)
    assert np.array_equal(est.theta, whole.theta[-1])
    est = FastRLS(n, **kw)
    parts = [est.run(Phi[a:b], y[a:b]) for a, b in ((0, 1), (1, 50), (50, N))]
    assert np.array_equal(np.concatenate([p.error for p in parts]), whole.error)
    B = FastRLS(n, **kw)
    bt = B.run_batched(np.stack([Phi, 2 * Phi]), np.stack([y, 2 * y]))
    assert np.array_equal(bt.error[0], whole.error)
    assert np.array_equal(bt.theta[0], whole.theta)
    assert B.theta.shape == (2, n) and np.array_equal(B.n_rescues, [0, 0])
    with pytest.raises(ValueError, match="single-stream"):
        B.update(Phi[0], 1.0)


@pytest.mark.parametrize("method", METHODS)
def test_state_files_and_pickle_resume_exactly(tmp_path, method):
    rng = np.random.default_rng(9)
    n, N = 7, 200
    u, y, _ = record(rng, n, N)
    kw = dict(forgetting=0.995, delta=0.02, method=method)
    whole = FastRLS(n, **kw).run_fir(u, y)
    est = FastRLS(n, **kw)
    est.run_fir(u[:80], y[:80])
    est.save_state(tmp_path / "s.npz")
    for other in (FastRLS.load_state(tmp_path / "s.npz"), adaptid.load_state(tmp_path / "s.npz"),
                  FastRLS.from_state(est.get_state()), pickle.loads(pickle.dumps(est)),
                  est.copy()):
        assert np.array_equal(other.run_fir(u[80:], y[80:]).error, whole.error[80:])
    RLS(n).save_state(tmp_path / "r.npz")
    with pytest.raises(StateFileError, match="not a FastRLS"):
        FastRLS.load_state(tmp_path / "r.npz")
    bad = est.get_state()
    # a negative forward energy (its square root for the lattice): no FastRLS holds it
    bad["state"][5 * n if method == "ftf" else 7 * n + 1] = -1.0
    with pytest.raises(ValueError, match="energies"):
        FastRLS.from_state(bad)


def test_skip_leaves_state_untouched_and_does_not_shift():
    rng = np.random.default_rng(11)
    n, N = 4, 150
    u, y, _ = record(rng, n, N)
    ref = FastRLS(n, forgetting=0.99, delta=0.1).run_fir(u, y)
    u2, y2 = np.insert(u, 40, np.nan), np.insert(y, 40, 1.0)
    u2, y2 = np.insert(u2, 90, 2.0), np.insert(y2, 90, np.nan)
    est = FastRLS(n, forgetting=0.99, delta=0.1, nan_policy="skip")
    t = est.run_fir(u2, y2)
    assert np.flatnonzero(t.skipped).tolist() == [40, 90] and est.n_skipped == 2
    assert np.array_equal(np.delete(t.error, [40, 90]), ref.error)
    assert np.array_equal(t.theta[40], t.theta[39])
    rows = np.insert(delay_rows(u, n), 40, np.nan, axis=0)
    est = FastRLS(n, forgetting=0.99, delta=0.1, nan_policy="skip")
    assert np.isnan(est.update(rows[0] * np.nan, 1.0)) and est.n_updates == 0
    t = est.run(rows, np.insert(y, 40, 0.0))
    assert np.array_equal(np.delete(t.error, 40), ref.error)


def test_refusals_name_the_argument_and_leave_the_state():
    est = FastRLS(3, forgetting=0.99, delta=1.0)
    est.update([1.0, 0.0, 0.0], 0.5)
    before = est.get_state()
    with pytest.raises(ValueError, match="phi must be a tapped delay line"):
        est.update([2.0, 0.5, 0.0], 1.0)  # phi[1] must be the previous input 1.0
    with pytest.raises(ValueError, match="Phi must be a tapped delay line.*row 1"):
        est.run(np.array([[2.0, 1.0, 0.0], [3.0, 2.0, 0.0]]), [1.0, 2.0])
    with pytest.raises(ValueError, match="phi and y must be finite"):
        est.update([np.nan, 1.0, 0.0], 1.0)
    with pytest.raises(ValueError, match="u must be finite"):
        est.run_fir([1.0, np.inf], [0.0, 0.0])
    after = est.get_state()
    assert np.array_equal(before["state"], after["state"])
    for kw, name in ((dict(forgetting=1.5), "forgetting"), (dict(forgetting=0.0), "forgetting"),
                     (dict(delta=0.0), "delta"), (dict(method="qr"), "method"),
                     (dict(nan_policy="fill"), "nan_policy"),
                     (dict(theta0=[1.0, 2.0]), "theta0")):
        with pytest.raises(ValueError, match=name):
            FastRLS(3, **kw)
    with pytest.raises(ValueError, match="n_taps"):
        FastRLS(0)


def test_rescue_outside_the_stable_range_keeps_tracking():
    # λ = 0.6 is far below 1 - 1/(2n) = 0.97 for n = 16: the error feedback does not
    # stabilise the FTF there; rescues must catch it and θ keep fitting noise-free data
    rng = np.random.default_rng(2)
    n, N = 16, 20000
    h = rng.standard_normal(n)
    u = rng.standard_normal(N)
    y = np.convolve(u, h)[:N]
    est = FastRLS(n, forgetting=0.6, delta=1e-6)
    t = est.run_fir(u, y)
    assert np.all(np.isfinite(t.error)) and np.all(np.isfinite(est.theta))
    assert est.n_rescues > 0 and t.meta["n_rescues"] == est.n_rescues
    np.testing.assert_allclose(est.theta, h, atol=1e-6)


def test_rescue_is_counted_after_a_corrupted_state():
    rng = np.random.default_rng(4)
    n, N = 8, 3000
    h = rng.standard_normal(n)
    u = rng.standard_normal(N)
    y = np.convolve(u, h)[:N]
    est = FastRLS(n, forgetting=0.99, delta=0.1)
    est.run_fir(u[:100], y[:100])
    st = est.get_state()
    st["state"][5 * n + 2] = 1e-300  # γ near 0: the next gain is garbage
    st["state"][3 * n: 4 * n] = 1e10
    est = FastRLS.from_state(st)
    t = est.run_fir(u[100:], y[100:])
    assert est.n_rescues >= 1 and t.meta["n_rescues"] == est.n_rescues
    np.testing.assert_allclose(est.theta, h, atol=1e-8)


def test_lattice_without_theta_track_gives_the_same_errors():
    rng = np.random.default_rng(12)
    n, N = 9, 300
    u, y, _ = record(rng, n, N)
    kw = dict(forgetting=0.99, delta=0.1, method="lattice")
    full = FastRLS(n, **kw).run_fir(u, y)
    est = FastRLS(n, track_theta=False, **kw)
    t = est.run_fir(u, y)
    assert np.array_equal(t.error, full.error) and t.theta.shape == (0, n)
    assert est.get_state()["state"].shape == (7 * n + 3,)  # O(n) state, no R
    with pytest.raises(ValueError, match="track_theta"):
        est.theta
    ftf = FastRLS(n, forgetting=0.99, delta=0.1).run_fir(u, y)
    assert rel(t.error, ftf.error) < 1e-9

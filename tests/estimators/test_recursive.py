"""The recursive estimators against the costs they minimise and against peers.

Oracles: the stacked weighted least-squares problem of DESIGN.md solved by
numpy.linalg.lstsq (tests/naive.py), statsmodels' RecursiveLS, filterpy's
KalmanFilter, padasip's FilterRLS and a textbook Kalman filter written here.
"""

import pickle

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st, HealthCheck

import adaptid
from adaptid.estimators import size_generic_kernels
from naive import kalman_random_walk, rls_cost_minimiser


def relerr(a, b):
    return np.max(np.abs(np.asarray(a) - np.asarray(b))) / max(np.max(np.abs(b)), 1e-300)


def make_data(rng, N, n, noise=0.1, p=None):
    Phi = rng.standard_normal((N, n))
    if p is None:
        theta = rng.standard_normal(n)
        y = Phi @ theta + noise * rng.standard_normal(N)
    else:
        theta = rng.standard_normal((n, p))
        y = Phi @ theta + noise * rng.standard_normal((N, p))
    return Phi, y, theta


# ----------------------------------------------------------------- RLS = cost
@pytest.mark.parametrize("case", ["lam1", "const", "per_sample", "weights", "matrixP0"])
def test_rls_equals_cost_minimiser(rng, case):
    N, n = 300, 4
    Phi, y, _ = make_data(rng, N, n)
    theta0 = rng.standard_normal(n)
    P0 = 10.0 * np.eye(n)
    lam = np.ones(N)
    w = np.ones(N)
    kw = {}
    if case == "const":
        lam[:] = 0.97
    elif case == "per_sample":
        lam = rng.uniform(0.9, 1.0, N)
        kw["forgetting"] = lam
    elif case == "weights":
        lam = rng.uniform(0.95, 1.0, N)
        w = rng.uniform(0.0, 3.0, N)
        w[::17] = 0.0
        kw.update(forgetting=lam, weights=w)
    elif case == "matrixP0":
        A = rng.standard_normal((n, n))
        P0 = A @ A.T + 0.5 * np.eye(n)
        lam[:] = 0.99
    est = adaptid.RLS(n, forgetting=lam[0] if case in ("const", "matrixP0") else 1.0,
                      theta0=theta0, P0=P0)
    traj = est.run(Phi, y, **kw)
    # after every 50th sample, and at the end
    for k in list(range(0, N, 50)) + [N - 1]:
        ref = rls_cost_minimiser(Phi[:k + 1], y[:k + 1], lam[:k + 1], w[:k + 1], theta0, P0)
        # 1e-9: the recursion is exact algebra; both sides are float64 solves of
        # a problem with condition number ~1e2-1e3
        assert relerr(traj.theta[k], ref) <= 1e-9, (case, k)
    # P is the inverse of half the Hessian of the cost
    logl = np.log(lam)
    tail = np.exp(np.concatenate([np.cumsum(logl[::-1])[::-1][1:], [0.0]])) * w
    H = (Phi * tail[:, None]).T @ Phi + np.exp(logl.sum()) * np.linalg.inv(P0)
    assert relerr(est.P @ H, np.eye(n)) <= 1e-9


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(n=st.integers(1, 6), N=st.integers(1, 60), lam=st.floats(0.8, 1.0),
       logP0=st.floats(-2, 4), seed=st.integers(0, 2**32 - 1), p=st.sampled_from([None, 1, 3]))
def test_rls_property_cost(n, N, lam, logP0, seed, p):
    rng = np.random.default_rng(seed)
    Phi, y, _ = make_data(rng, N, n, p=p)
    theta0 = rng.standard_normal(n if p is None else (n, p))
    P0 = 10.0 ** logP0
    # the size-generic kernel: one compilation for the six sizes drawn (the
    # specialised kernels equal it bit for bit: tests/kernels/test_kernels_scratch.py)
    with size_generic_kernels():
        est = adaptid.RLS(n, forgetting=lam, theta0=theta0, P0=P0, n_outputs=p)
    w = rng.uniform(0.1, 2.0, N)
    est.run(Phi, y, weights=w)
    ref = rls_cost_minimiser(Phi, y, np.full(N, lam), w, theta0, P0 * np.eye(n))
    # 1e-8: random problems reach condition numbers ~1e5 (P0 = 1e4 with few samples)
    assert relerr(est.theta, ref) <= 1e-8


def test_rls_diffuse_prior_equals_ols_every_step(rng):
    """λ = 1, P0 = 1e10: the recursion equals OLS on the first k samples, k ≥ n+1."""
    import statsmodels.api as sm
    N, n = 400, 5
    Phi, y, _ = make_data(rng, N, n)
    Phi[:, 0] = 1.0
    Phi[:, 1] *= 50.0  # unequal scales: a harder case for the plain covariance form
    est = adaptid.RLS(n, P0=1e10)
    traj = est.run(Phi, y)
    ols = np.array([np.linalg.lstsq(Phi[:k + 1], y[:k + 1], rcond=None)[0] for k in range(n, N)])
    errs = np.abs(traj.theta[n:] - ols) / np.max(np.abs(ols), axis=1, keepdims=True)
    # 1e-6 relative is the bound; the prior contributes ~1e-10 relative
    assert errs.max() <= 1e-6
    res = sm.RecursiveLS(y, Phi).fit()
    rec = np.asarray(res.recursive_coefficients.filtered).T
    assert relerr(traj.theta[-1], rec[-1]) <= 1e-6
    errs_sm = np.abs(traj.theta[2 * n:] - rec[2 * n:]) / np.max(np.abs(rec[2 * n:]), axis=1, keepdims=True)
    assert errs_sm.max() <= 1e-6


# --------------------------------------------------------------- sliding window
def _windowed_batch(Phi, y, lam, w, theta0, P0, M):
    """Oracle at every step, vectorised: batched QR of every window's stacked system."""
    N, n = Phi.shape
    logl = np.log(lam)
    L = np.concatenate([[0.0], np.cumsum(logl)])  # L[k+1] = Σ_{i≤k} log λ_i
    Lc = np.linalg.cholesky(P0)
    Linv = np.linalg.solve(Lc, np.eye(n))
    out = np.empty((N, n))
    idx = np.arange(N)
    for k0 in range(0, N, 4096):
        ks = idx[k0:k0 + 4096]
        K = len(ks)
        js = ks[:, None] - np.arange(M)[None, ::-1]          # window indices (K, M)
        valid = js >= 0
        jc = np.clip(js, 0, None)
        c = np.where(valid, np.exp(L[ks + 1][:, None] - L[jc + 1]) * w[jc], 0.0)
        sc = np.sqrt(c)
        A = np.concatenate([sc[..., None] * Phi[jc], np.sqrt(np.exp(L[ks + 1]))[:, None, None] * Linv[None]], axis=1)
        b = np.concatenate([sc * y[jc], np.sqrt(np.exp(L[ks + 1]))[:, None] * (Linv @ theta0)[None]], axis=1)
        Q, R = np.linalg.qr(A)
        out[ks] = np.linalg.solve(R, np.einsum("kmi,km->ki", Q, b)[..., None])[..., 0]
    return out


@pytest.mark.parametrize("case", ["lam1", "const", "per_sample_weights"])
def test_window_equals_windowed_batch_no_drift(rng, case):
    N, n, M = 100_000, 4, 50
    Phi, y, _ = make_data(rng, N, n)
    theta0 = np.zeros(n)
    P0 = 1e4 * np.eye(n)
    lam = np.ones(N)
    w = np.ones(N)
    kw = {}
    forgetting = 1.0
    if case == "const":
        lam[:] = 0.98
        forgetting = 0.98
    elif case == "per_sample_weights":
        lam = rng.uniform(0.95, 1.0, N)
        w = rng.uniform(0.2, 2.0, N)
        kw.update(forgetting=lam, weights=w)
    est = adaptid.SlidingWindowRLS(n, M, forgetting=forgetting, theta0=theta0, P0=P0)
    traj = est.run(Phi, y, **kw)
    ref = _windowed_batch(Phi, y, lam, w, theta0, P0, M)
    err = np.abs(traj.theta - ref).max(axis=1) / np.abs(ref).max(axis=1)
    # 1e-8 relative at every one of the 1e5 steps (no drift of the downdates)
    assert err.max() <= 1e-8, (case, err.argmax(), err.max())
    assert traj.n_rebuilds == 0


def test_window_exact_after_jump(rng):
    n, M, N, t0 = 4, 50, 400, 200
    Phi = rng.standard_normal((N, n))
    th1, th2 = rng.standard_normal(n), rng.standard_normal(n)
    y = np.where(np.arange(N) < t0, Phi @ th1, Phi @ th2)
    est = adaptid.SlidingWindowRLS(n, M, P0=1e12)
    traj = est.run(Phi, y)
    # sample index t0 is the first with the new θ; the window holds only new
    # samples after index t0 + M - 1
    after = t0 + M - 1
    assert relerr(traj.theta[after], th2) <= 1e-6
    assert relerr(traj.theta[after - 1], th2) > 1e-3     # not before
    assert relerr(traj.theta[after:], np.broadcast_to(th2, (N - after, n))) <= 1e-6


def test_window_rebuild_on_definiteness_loss(rng):
    """A window whose removal would lose definiteness is re-solved and warned about."""
    n, M = 2, 3
    Phi = np.array([[1.0, 0.0], [0.0, 1.0], [0.0, 1.0], [0.0, 1.0], [0.0, 1.0]])
    y = np.array([1.0, 2.0, 2.0, 2.0, 2.0])
    est = adaptid.SlidingWindowRLS(n, M, P0=1e15)
    with pytest.warns(adaptid.DefinitenessLossWarning):
        traj = est.run(Phi, y)
    assert traj.n_rebuilds >= 1
    ref = rls_cost_minimiser(Phi, y, np.ones(5), np.ones(5), np.zeros(n), 1e15 * np.eye(n), first=2)
    assert relerr(est.theta, ref) <= 1e-9
    assert np.all(np.linalg.eigvalsh(est.P) > 0)


# ---------------------------------------------------------------------- Kalman
def test_kalman_equals_textbook_and_filterpy(rng):
    from filterpy.kalman import KalmanFilter
    N, n = 500, 3
    Phi, _, _ = make_data(rng, N, n)
    theta = np.cumsum(0.05 * rng.standard_normal((N, n)), axis=0)
    y = np.einsum("ki,ki->k", Phi, theta) + 0.3 * rng.standard_normal(N)
    Q = np.diag([1e-3, 2e-3, 5e-4])
    r2 = 0.09
    theta0 = np.array([0.1, -0.2, 0.3])
    est = adaptid.KalmanRLS(n, process_cov=Q, noise_var=r2, theta0=theta0, P0=5.0)
    traj = est.run(Phi, y)
    ref, err, Pref = kalman_random_walk(Phi, y, Q, r2, theta0, 5.0 * np.eye(n))
    # 1e-10: the same recursion in two algebraically equivalent forms
    assert relerr(traj.theta, ref) <= 1e-10
    assert relerr(traj.error, err) <= 1e-10
    assert relerr(est.P, Pref) <= 1e-10
    kf = KalmanFilter(dim_x=n, dim_z=1)
    kf.x = theta0.reshape(n, 1).copy()
    kf.P = 5.0 * np.eye(n)
    kf.F = np.eye(n)
    kf.Q = Q
    kf.R = np.array([[r2]])
    xs = np.empty((N, n))
    for k in range(N):
        kf.H = Phi[k].reshape(1, n)
        kf.update(y[k])
        kf.predict()
        xs[k] = kf.x[:, 0]
    assert relerr(traj.theta, xs) <= 1e-9
    assert relerr(est.P, kf.P) <= 1e-9


def test_padasip_filter_rls_same_trajectory(rng):
    import padasip as pa
    N, n = 400, 4
    Phi, y, _ = make_data(rng, N, n)
    lam, eps = 0.98, 0.01
    f = pa.filters.FilterRLS(n, mu=lam, eps=eps, w="zeros")
    _, e_pa, w_pa = f.run(y, Phi)
    est = adaptid.RLS(n, forgetting=lam, P0=1.0 / eps)
    traj = est.run(Phi, y)
    # padasip records the weights before each update: its row k is our row k-1
    assert relerr(traj.error, e_pa) <= 1e-9
    assert relerr(traj.theta[:-1], w_pa[1:]) <= 1e-9
    assert relerr(est.theta, f.w) <= 1e-9


# --------------------------------------------- equivalences of the interfaces
# the three recursions with a covariance, as the tests below build them
THREE = pytest.mark.parametrize("make", [
    lambda: adaptid.RLS(3, forgetting=0.97, P0=100.0),
    lambda: adaptid.SlidingWindowRLS(3, 20, forgetting=0.99, P0=100.0),
    lambda: adaptid.KalmanRLS(3, process_cov=1e-3, noise_var=0.5),
], ids=["rls", "window", "kalman"])


@THREE
def test_run_equals_updates_bit_for_bit(rng, make):
    Phi, y, _ = make_data(rng, 300, 3)
    a, b = make(), make()
    traj = a.run(Phi, y)
    errs = np.array([b.update(Phi[k], y[k]) for k in range(300)])
    assert np.array_equal(traj.error, errs)
    assert np.array_equal(a.theta, b.theta)
    assert np.array_equal(a.P, b.P)
    assert a.n_updates == b.n_updates == 300


@pytest.mark.parametrize("form,n", [("ud", 4), ("sqrt", 17), ("covariance", 3)])
def test_the_step_kernels_are_steps_of_run(rng, form, n):
    """update's narrow step entries (adaptid._kernels.recursions._step), called on packed samples
    one by one, give run's state and errors bit for bit: compiled, and in CI's
    NUMBA_DISABLE_JIT=1 step also as plain Python."""
    from adaptid._kernels.recursions import _step
    N = 60
    Phi, y, _ = make_data(rng, N, n)
    Phi[7, 0] = np.nan  # skipped
    w = rng.uniform(0.5, 2.0, N)
    w[11] = 0.0
    lam = rng.uniform(0.95, 1.0, N)
    ref = adaptid.RLS(n, forgetting=0.98, form=form, nan_policy="skip")
    tr = ref.run(Phi, y, weights=w, forgetting=lam)
    est = adaptid.RLS(n, forgetting=0.98, form=form, nan_policy="skip")
    S = est._S.copy()
    at = _step.layout(n, 1)
    W = np.zeros((1, 1, at.width))
    R = W[0, 0]
    R[at.threshold] = est._opt[0]
    errors, skipped = [], []
    for k in range(N):
        R[:n], R[at.y], R[at.lam], R[at.w] = Phi[k], y[k], lam[k], w[k]
        est._kern.step(S, W, est._ntag, est._ptag)
        errors.append(R[at.e])
        skipped.append(R[at.skipped] == 1.0)
        R[at.skipped] = 0.0
    assert np.array_equal(S, ref._S)
    assert np.array_equal(np.array(errors), tr.error, equal_nan=True)
    assert np.array_equal(np.array(skipped), tr.skipped) and skipped[7]


@THREE
def test_updates_and_short_runs_compile_nothing_after_a_run(rng, make):
    """One compiled signature serves run, update and runs of 0 or 1 sample, with
    scalar or per-sample weights and forgetting (numpy flags every array of at
    most one element contiguous: the engine keeps λ and w non-contiguous)."""
    Phi, y, _ = make_data(rng, 40, 3)
    est = make()
    est.run(Phi[:30], y[:30])
    kernel = est._kern.run
    # (NUMBA_DISABLE_JIT=1: a plain function, nothing compiled; the equality below still holds)
    before = getattr(kernel, "signatures", [])  # (a new list at each access)
    est.update(Phi[30], y[30])
    est.update(Phi[31], y[31], weight=0.5)
    est.run(Phi[32:33], y[32:33])
    est.run(Phi[33:34], y[33:34], weights=[0.7])
    est.run(Phi[34:34], y[34:34])
    est.run(Phi[34:37], y[34:37], weights=np.array([1.0, 0.5, 2.0]))
    if isinstance(est, adaptid.RLS):
        est.run(Phi[37:38], y[37:38], forgetting=np.array([0.9]))
    assert getattr(kernel, "signatures", []) == before
    # and the short runs are the updates: a second estimator fed sample by sample
    ref = make()
    ref.run(Phi[:30], y[:30])
    for k, w in zip(range(30, 37), [1.0, 0.5, 1.0, 0.7, 1.0, 0.5, 2.0]):
        ref.update(Phi[k], y[k], weight=w)
    if isinstance(est, adaptid.RLS):
        ref.update(Phi[37], y[37], forgetting=0.9)
    assert np.array_equal(ref.theta, est.theta)


@THREE
def test_update_takes_any_spelling_of_phi(rng, make):
    """update's fast path (a native float64 array of shape (n,), copied as it is) and
    its conversion path (anything else) give the same bits: a big-endian float64 φ,
    a strided view, a list, and a float32 φ against the float64 of its values."""
    Phi, y, _ = make_data(rng, 24, 3)
    ref, est = make(), make()
    big = Phi.astype(">f8")
    wide = np.repeat(Phi, 2, axis=1)[:, ::2]  # non-contiguous rows, same values
    for k in range(24):
        spelt = (big[k], wide[k], Phi[k].tolist(), Phi[k].astype(np.float32))[k % 4]
        phi = Phi[k] if k % 4 < 3 else Phi[k].astype(np.float32).astype(np.float64)
        e_ref = ref.update(phi, y[k])
        e = est.update(spelt, y[k])
        assert type(e) is float and (e == e_ref)
    assert np.array_equal(ref.theta, est.theta) and np.array_equal(ref.P, est.P)


@THREE
def test_batched_equals_single_runs(rng, make):
    B, N, n = 7, 200, 3
    Phi = rng.standard_normal((B, N, n))
    y = np.einsum("bni,i->bn", Phi, [1.0, -1.0, 0.5]) + 0.1 * rng.standard_normal((B, N))
    est = make()
    tb = est.run_batched(Phi, y)
    assert tb.theta.shape == (B, N, n) and tb.error.shape == (B, N)
    assert est.theta.shape == (B, n) and est.P.shape == (B, n, n)
    for s in range(B):
        single = make()
        ts = single.run(Phi[s], y[s])
        assert np.array_equal(ts.theta, tb.theta[s])
        assert np.array_equal(single.P, est.P[s])
    with pytest.raises(ValueError, match="run_batched"):
        est.update(Phi[0, 0], y[0, 0])


@pytest.mark.parametrize("make", [
    lambda p: adaptid.RLS(3, forgetting=0.97, P0=100.0, n_outputs=p),
    lambda p: adaptid.SlidingWindowRLS(3, 20, P0=100.0, n_outputs=p),
    lambda p: adaptid.KalmanRLS(3, process_cov=1e-3, n_outputs=p),
], ids=["rls", "window", "kalman"])
def test_multi_output_equals_single_outputs(rng, make):
    Phi, Y, _ = make_data(rng, 250, 3, p=4)
    est = make(4)
    tr = est.run(Phi, Y)
    assert tr.theta.shape == (250, 3, 4) and est.theta.shape == (3, 4)
    for j in range(4):
        s = make(None)
        ts = s.run(Phi, Y[:, j])
        # same operations in the same order on the shared P
        assert np.array_equal(ts.theta, tr.theta[:, :, j])
        assert np.array_equal(s.P, est.P)


@THREE
def test_state_round_trip_resume_bit_for_bit(rng, make, tmp_path):
    Phi, y, _ = make_data(rng, 400, 3)
    k = int(rng.integers(1, 399))
    whole = make()
    tw = whole.run(Phi, y)
    first = make()
    first.run(Phi[:k], y[:k])
    for resumed in (type(first).from_state(first.get_state()),
                    pickle.loads(pickle.dumps(first)),
                    first.copy()):
        tr = resumed.run(Phi[k:], y[k:])
        assert np.array_equal(tr.theta, tw.theta[k:])
        assert np.array_equal(resumed.P, whole.P)
        assert resumed.n_updates == 400
    path = tmp_path / "state.npz"
    first.save_state(path)
    loaded = type(first).load_state(path)
    tl = loaded.run(Phi[k:], y[k:])
    assert np.array_equal(tl.theta, tw.theta[k:])


def test_reset_and_predict(rng):
    Phi, y, th = make_data(rng, 200, 3, noise=0.0)
    est = adaptid.RLS(3, P0=1e8)
    est.run(Phi, y)
    assert np.allclose(est.predict(Phi[:5]), y[:5])
    assert np.isclose(est.predict(Phi[0]), y[0])
    est.reset()
    assert est.n_updates == 0 and np.array_equal(est.theta, np.zeros(3))
    assert np.allclose(est.P, 1e8 * np.eye(3))


# --------------------------------------------------------------------- errors
BAD_CONSTRUCTORS = [
    (lambda: adaptid.RLS(0), "n_params"),
    (lambda: adaptid.RLS(2, forgetting=1.2), "forgetting"),
    (lambda: adaptid.RLS(2, forgetting=0.0), "forgetting"),
    (lambda: adaptid.RLS(2, P0=-1.0), "P0"),
    (lambda: adaptid.RLS(2, P0=np.array([[1.0, 2.0], [2.0, 1.0]])), "P0"),
    (lambda: adaptid.RLS(2, P0=np.array([[1.0, 0.5], [0.0, 1.0]])), "P0"),
    (lambda: adaptid.RLS(2, P0=np.ones((3, 3))), "P0"),
    (lambda: adaptid.RLS(2, theta0=[1.0, 2.0, 3.0]), "theta0"),
    (lambda: adaptid.RLS(2, theta0=[np.nan, 2.0]), "theta0"),
    (lambda: adaptid.RLS(2, nan_policy="ignore"), "nan_policy"),
    (lambda: adaptid.SlidingWindowRLS(4, 3), "window"),
    (lambda: adaptid.KalmanRLS(2, process_cov=-1.0), "process_cov"),
    (lambda: adaptid.KalmanRLS(2, process_cov=np.diag([1.0, -1.0])), "process_cov"),
    (lambda: adaptid.KalmanRLS(2, process_cov=0.1, noise_var=0.0), "noise_var"),
]


@pytest.mark.parametrize("build,name", BAD_CONSTRUCTORS)
def test_bad_constructor_arguments(build, name):
    with pytest.raises(ValueError, match=name):
        build()


@pytest.mark.parametrize("make", [
    lambda: adaptid.RLS(2, forgetting=0.9),
    lambda: adaptid.SlidingWindowRLS(2, 5),
    lambda: adaptid.KalmanRLS(2, process_cov=0.1),
], ids=["rls", "window", "kalman"])
def test_failed_update_leaves_state_unchanged(rng, make):
    est = make()
    Phi, y, _ = make_data(rng, 20, 2)
    est.run(Phi, y)
    before = est.get_state()
    cases = [
        ((np.array([np.nan, 1.0]), 1.0), {}, "phi"),
        ((np.array([1.0, 1.0]), np.inf), {}, "y"),
        ((np.ones(3), 1.0), {}, "phi"),
        ((np.ones(2), 1.0), {"weight": -1.0}, "weight"),
    ]
    if not isinstance(est, adaptid.KalmanRLS):
        cases.append(((np.ones(2), 1.0), {"forgetting": 1.5}, "forgetting"))
    for args, kw, name in cases:
        with pytest.raises(ValueError, match=name):
            est.update(*args, **kw)
        after = est.get_state()
        assert np.array_equal(after["state"], before["state"]) and after["n_updates"] == before["n_updates"]
    for bad_run, name in [
        (lambda: est.run(np.ones((5, 3)), np.ones(5)), "Phi"),
        (lambda: est.run(np.ones((5, 2)), np.ones(4)), "y"),
        (lambda: est.run(np.full((5, 2), np.nan), np.ones(5)), "Phi"),
        (lambda: est.run(np.ones((5, 2)), np.ones(5), weights=-np.ones(5)), "weights"),
    ]:
        with pytest.raises(ValueError, match=name):
            bad_run()
        assert np.array_equal(est.get_state()["state"], before["state"])


def test_nan_skip_counts_and_leaves_rls_state(rng):
    Phi, y, _ = make_data(rng, 100, 3)
    y[10] = np.nan
    Phi[20, 1] = np.inf
    est = adaptid.RLS(3, nan_policy="skip")
    tr = est.run(Phi, y)
    assert tr.skipped.sum() == 2 and est.n_skipped == 2 and est.n_updates == 98
    assert np.isnan(tr.error[10]) and np.array_equal(tr.theta[10], tr.theta[9])
    ref = adaptid.RLS(3)
    keep = ~tr.skipped
    ref.run(Phi[keep], y[keep])
    assert np.array_equal(ref.theta, est.theta)


def test_public_names_do_not_leak():
    import adaptid as a
    assert set(a.__all__) >= {"RLS", "SlidingWindowRLS", "KalmanRLS", "Trajectory", "lstsq",
                              "LSResult", "constrained_lstsq", "piecewise_polyfit",
                              "lq_control", "lq_estimate", "recursive_residuals", "cusum",
                              "cusum_squares"}
    public = {k for k in dir(a) if not k.startswith("_")}
    assert public <= set(a.__all__) | {"forgetting", "constrained", "continuous", "models", "estimators", "plot", "io",
                                       "diagnostics", "datasets", "fleet", "sklearn"}


def test_estimators_exports_only_public_names():
    """``adaptid.estimators`` exports the contract's names only; the engine, the
    factory's tables and the state-class registry stay in their private modules."""
    import adaptid.estimators as e
    assert set(e.__all__) == {"RLS", "SlidingWindowRLS", "KalmanRLS", "LMS", "NLMS",
                              "Trajectory", "SegmentResult", "WindowStats", "estimator",
                              "recursive_fit_stats", "RecursiveFitStats", "KernelSettings",
                              "load_state", "save_state", "size_generic_kernels",
                              "FastRLS"}  # FastRLS: issue 38
    public = {k for k in dir(e) if not k.startswith("_")}
    assert public == set(e.__all__)


@pytest.mark.parametrize("method", ["rls", "window", "kalman", "lms", "nlms"])
def test_each_algorithm_declares_one_spec(method):
    """An algorithm is declared by one AlgorithmSpec (no boolean class flags); its
    options are the factory's for its method (the state's options, in order)."""
    from adaptid.estimators._engine import RecursiveEstimator
    from adaptid.estimators._factory import method_options
    from adaptid.estimators._spec import AlgorithmSpec
    cls = type(adaptid.estimator(method, 2, **{"window": {"window": 5},
                                               "kalman": {"process_cov": 0.1},
                                               "lms": {"step": 0.1},
                                               "nlms": {"step": 0.1}}.get(method, {})))
    assert isinstance(cls.spec, AlgorithmSpec) and cls.spec.method == method
    flags = ("_code_is_rebuilds", "_reports_forgetting", "_has_covariance",
             "_supports_stats", "_stats_from_buffer", "_kind", "_method")
    assert not any(hasattr(cls, f) for f in flags)
    common = {"theta0", "P0", "n_outputs", "nan_policy", "windup_threshold"}
    assert set(cls.spec.options) - common == set(method_options(method)) - common
    assert issubclass(cls, RecursiveEstimator) and RecursiveEstimator.spec is None

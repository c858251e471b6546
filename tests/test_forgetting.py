"""Forgetting strategies, windup monitoring and long-run stability (issue 3).

Oracles: textbook P-form (and information-form) recursions written here with
NumPy from the papers' equations; ``numpy.linalg.lstsq`` on exponentially
weighted windows; filterpy's KalmanFilter.
"""

import warnings

import numpy as np
import pytest

import adaptid
from adaptid import forgetting as fg

from conftest import SOAK

#: the forms of RLS with exponential forgetting (issue 19): every stability test runs in each
FORMS = ("ud", "sqrt", "covariance")

STRATEGIES = {
    "exponential": lambda: fg.Exponential(0.97),
    "directional": lambda: fg.Directional(0.97),
    "constant_trace": lambda: fg.ConstantTrace(0.9, 5.0),
    "efra": lambda: fg.EFRA(0.5, 0.005, 0.005, 0.95),
    "variable": lambda: fg.Variable(0.9, 0.1, 200.0),
}


def ud(P):
    """Upper U-D factors P = U diag(D) Uᵀ via the Cholesky factor of the reversed matrix."""
    L = np.linalg.cholesky(P[::-1, ::-1])
    Ut = L[::-1, ::-1]
    d = np.diag(Ut).copy()
    return Ut / d, d * d


# --------------------------------------------------------------------------
# textbook recursions (P form, NumPy) — the oracle for each strategy
# --------------------------------------------------------------------------
def naive_strategy(strategy, Phi, y, P0, *, w=None, P_max=None):
    n = Phi.shape[1]
    theta = np.zeros(n)
    P = np.eye(n) * P0
    Th = np.empty_like(Phi)
    lams = np.empty(len(y))
    w = np.ones(len(y)) if w is None else w
    for k, (phi, yk, wk) in enumerate(zip(Phi, y, w)):
        e = yk - phi @ theta
        r = phi @ P @ phi
        if isinstance(strategy, (fg.Exponential, fg.Variable)):
            if isinstance(strategy, fg.Exponential):
                lk = strategy.lam
            else:  # Fortescue et al. (1981)
                lk = max(strategy.lam_min,
                         1 - wk * e * e / ((1 + wk * r) * strategy.sigma0 ** 2 * strategy.memory))
            if P_max is not None:  # pivot-wise conditional forgetting
                U, d = ud(P)
                li = np.where(d > lk * P_max, np.minimum(1.0, np.maximum(lk, d / P_max)), lk)
                P = U @ np.diag(d / li) @ U.T
            else:
                P = P / lk
            K = P @ phi / (1 / wk + phi @ P @ phi)
            theta = theta + K * e
            P = P - np.outer(K, phi @ P)
        elif isinstance(strategy, fg.Directional):  # Kulhavý (1987), information form
            lk = strategy.lam
            if P_max is not None and np.max(np.diag(P)) > lk * P_max:
                lk = 1.0
            R = np.linalg.inv(P)
            if r > 0 and lk < 1:
                R = R - (1 - lk) * np.outer(phi, phi) / r
            R = R + wk * np.outer(phi, phi)
            Pn = np.linalg.inv(R)
            theta = theta + wk * Pn @ phi * e
            P = Pn
        elif isinstance(strategy, fg.ConstantTrace):
            K = P @ phi / (1 / wk + r)
            theta = theta + K * e
            P = P - np.outer(K, phi @ P)
            c1 = (1 - strategy.floor) * strategy.trace
            c2 = strategy.floor * strategy.trace / n
            g = min(c1 / np.trace(P), 1 / strategy.lam)
            P = g * P + c2 * np.eye(n)
            lk = 1 / g
        else:  # EFRA, Salgado, Goodwin & Middleton (1988)
            a, b, d, lk = strategy.alpha, strategy.beta, strategy.delta, strategy.lam
            Pold = P
            g = P @ phi / (1 / wk + r)
            theta = theta + a * g * e
            P = (P - a * np.outer(g, phi @ P)) / lk + b * np.eye(n) - d * Pold @ Pold
        P = 0.5 * (P + P.T)
        Th[k] = theta
        lams[k] = lk
    return Th, P, lams


@pytest.mark.parametrize("name", sorted(STRATEGIES))
def test_strategy_equals_textbook_recursion(rng, name):
    strategy = STRATEGIES[name]()
    n, N = 3, 1500
    Phi = rng.standard_normal((N, n))
    Phi[600:900, 2] = 0.0            # a stretch with one direction unexcited
    y = Phi @ [1.0, -0.5, 2.0] + 0.1 * rng.standard_normal(N)
    y[1000:] += Phi[1000:, 0] * 0.7  # a change
    w = rng.uniform(0.5, 2.0, N)
    est = adaptid.RLS(n, forgetting=strategy, P0=10.0)
    tr = est.run(Phi, y, weights=w)
    Th, P, lams = naive_strategy(strategy, Phi, y, 10.0, w=w)
    np.testing.assert_allclose(tr.theta, Th, rtol=1e-8, atol=1e-9)
    np.testing.assert_allclose(est.P, P, rtol=1e-8, atol=1e-11)
    if name not in ("directional", "exponential"):  # constant λ is not reported back
        np.testing.assert_allclose(tr.forgetting, lams, rtol=1e-12)


@pytest.mark.parametrize("strategy", [fg.Exponential(0.95), fg.Directional(0.95),
                                      fg.Variable(0.9, 0.05, 100.0)], ids=repr)
def test_P_max_equals_textbook_conditional_forgetting(rng, strategy):
    n, N = 2, 3000
    Phi = rng.standard_normal((N, n))
    Phi[500:, 1] = 0.0
    y = Phi @ [1.0, 2.0] + 0.05 * rng.standard_normal(N)
    est = adaptid.RLS(n, forgetting=strategy, P_max=50.0, P0=1.0)
    tr = est.run(Phi, y)
    Th, P, _ = naive_strategy(strategy, Phi, y, 1.0, P_max=50.0)
    np.testing.assert_allclose(tr.theta, Th, rtol=1e-8, atol=1e-9)
    np.testing.assert_allclose(est.P, P, rtol=1e-8, atol=1e-11)
    if not isinstance(strategy, fg.Directional):
        assert np.max(ud(est.P)[1]) <= 50.0 * (1 + 1e-9)
    else:
        assert np.max(np.diag(est.P)) <= 50.0 * (1 + 1e-9)


def test_float_and_exponential_are_the_same(rng):
    Phi = rng.standard_normal((500, 3))
    y = Phi @ [1, 2, 3] + rng.standard_normal(500)
    a = adaptid.RLS(3, forgetting=0.98)
    b = adaptid.RLS(3, forgetting=fg.Exponential(0.98))
    ta, tb = a.run(Phi, y), b.run(Phi, y)
    assert np.array_equal(ta.theta, tb.theta) and np.array_equal(a.P, b.P)
    assert tb.forgetting is None  # constant λ: nothing to report


@pytest.mark.parametrize("name", sorted(STRATEGIES))
def test_strategy_run_equals_updates_batched_segments_and_state(rng, name, tmp_path):
    strategy = STRATEGIES[name]()
    n, N = 3, 400
    Phi = rng.standard_normal((2, N, n))
    y = Phi @ [0.5, -1.0, 1.5] + 0.1 * rng.standard_normal((2, N))
    y[0, 17] = np.nan
    make = lambda: adaptid.RLS(n, forgetting=strategy, P0=100.0, nan_policy="skip")  # noqa: E731
    ref = make()
    tr = ref.run(Phi[0], y[0])
    one = make()
    errs = [one.update(Phi[0, k], y[0, k]) for k in range(N)]
    assert np.array_equal(one.get_state()["state"], ref.get_state()["state"])
    np.testing.assert_array_equal(np.array(errs), tr.error)
    # batched == single
    bt = make()
    tb = bt.run_batched(Phi, y)
    assert np.array_equal(tb.theta[0], tr.theta)
    if tr.forgetting is not None:
        assert np.array_equal(tb.forgetting[0], tr.forgetting, equal_nan=True)
    # segments == single
    seg = make().run_segments(Phi.reshape(-1, n), y.reshape(-1), [0, N, 2 * N])
    assert np.array_equal(seg.theta[0], ref.theta) and np.array_equal(seg.P[0], ref.P)
    # state round trip (dict and file) resumes bit for bit
    half = make()
    half.run(Phi[0, :200], y[0, :200])
    path = tmp_path / "s.npz"
    half.save_state(path)
    for resumed in (adaptid.RLS.from_state(half.get_state()), adaptid.RLS.load_state(path)):
        assert resumed.forgetting == strategy
        resumed.run(Phi[0, 200:], y[0, 200:])
        assert np.array_equal(resumed.get_state()["state"], ref.get_state()["state"])


def test_strategy_arguments_are_validated():
    with pytest.raises(ValueError, match="lam must be in \\(0.0, 1.0\\]"):
        fg.Directional(1.5)
    with pytest.raises(ValueError, match="trace must be"):
        fg.ConstantTrace(0.9, 0.0)
    with pytest.raises(ValueError, match="alpha must be"):
        fg.EFRA(alpha=0.0)
    with pytest.raises(ValueError, match="memory must be"):
        fg.Variable(0.9, 1.0, 0.5)
    with pytest.raises(ValueError, match="P_max must be None with EFRA"):
        adaptid.RLS(2, forgetting=fg.EFRA(), P_max=10.0)
    with pytest.raises(ValueError, match="forgetting must be a float or adaptid.forgetting.Exponential"):
        adaptid.SlidingWindowRLS(2, 10, forgetting=fg.Directional(0.9))
    est = adaptid.RLS(2, forgetting=fg.Directional(0.9))
    with pytest.raises(ValueError, match="forgetting must be None"):
        est.update([1.0, 2.0], 1.0, forgetting=0.5)
    with pytest.raises(ValueError, match="forgetting must be a dict naming"):
        fg.from_dict({"strategy": "Nope"})
    assert fg.from_dict(fg.EFRA().to_dict()) == fg.EFRA()


def test_window_accepts_exponential_object(rng):
    Phi = rng.standard_normal((300, 2))
    y = Phi @ [1.0, 2.0]
    a = adaptid.SlidingWindowRLS(2, 50, forgetting=0.99)
    b = adaptid.SlidingWindowRLS(2, 50, forgetting=fg.Exponential(0.99))
    assert np.array_equal(a.run(Phi, y).theta, b.run(Phi, y).theta)


# --------------------------------------------------------------------------
# windup: one direction unexcited for 10⁶ steps, then a jump
# --------------------------------------------------------------------------
N_QUIET = 1_000_000
THETA_A = np.array([1.0, -1.0])
THETA_B = np.array([1.5, -0.4])


def _quiet_then_jump(rng, n_quiet):
    """n_quiet steps exciting only φ₁, then 3000 well-excited steps after θ jumps."""
    u = rng.standard_normal(n_quiet)
    Phi_q = np.column_stack([u, np.zeros(n_quiet)])
    y_q = Phi_q @ THETA_A + 0.01 * rng.standard_normal(n_quiet)
    Phi_j = rng.standard_normal((3000, 2))
    y_j = Phi_j @ THETA_B + 0.01 * rng.standard_normal(3000)
    return Phi_q, y_q, Phi_j, y_j


def _delay(theta_track, target, tol=0.05):
    """Samples until the estimate stays within tol·|target| of target."""
    err = np.linalg.norm(theta_track - target, axis=1) / np.linalg.norm(target)
    bad = np.flatnonzero(err > tol)
    return 0 if bad.size == 0 else int(bad[-1] + 1)


BOUNDED = {
    "directional": dict(forgetting=fg.Directional(0.98)),
    "constant_trace": dict(forgetting=fg.ConstantTrace(0.98, 2.0)),
    "efra": dict(forgetting=fg.EFRA(0.5, 0.005, 0.005, 0.98)),
    "P_max": dict(forgetting=0.98, P_max=10.0),
}


def _efra_bound(s):
    # fixed point of p ← p/λ + β − δp² (an unexcited direction): the largest
    # eigenvalue P can reach (Salgado et al. 1988, Theorem 1)
    a = 1 / s.lam - 1
    return (a + np.sqrt(a * a + 4 * s.delta * s.beta)) / (2 * s.delta)


@pytest.mark.parametrize("form", FORMS)
def test_exponential_forgetting_winds_up_and_warns(rng, form):
    Phi_q, y_q, _, _ = _quiet_then_jump(rng, 20_000)
    est = adaptid.RLS(2, forgetting=0.98, P0=1.0, form=form)
    with pytest.warns(adaptid.CovarianceWindupWarning, match="windup"):
        est.run(Phi_q, y_q)
    # the unexcited direction's variance grows like λ^-k: 0.98^-20000 overflows
    assert not np.all(np.isfinite(est.P)) or est.P[1, 1] > 1e100


@pytest.mark.parametrize("name", sorted(BOUNDED))
def test_bounded_strategies_survive_a_million_quiet_steps_and_track(rng, name):
    opts = BOUNDED[name]
    Phi_q, y_q, Phi_j, y_j = _quiet_then_jump(rng, N_QUIET)
    est = adaptid.RLS(2, P0=1.0, **opts)
    traces = []
    with warnings.catch_warnings():
        warnings.simplefilter("error", adaptid.CovarianceWindupWarning)
        for chunk in np.array_split(np.arange(N_QUIET), 50):
            est.run(Phi_q[chunk], y_q[chunk], store=False)
            traces.append(np.trace(est.P))
        assert np.all(np.linalg.eigvalsh(est.P) > 0)
        track = est.run(Phi_j, y_j).theta
    traces = np.array(traces)
    n = 2
    s = opts["forgetting"]
    if name == "directional":
        bound = n * 1.0            # never above the prior: the quiet direction is not forgotten
    elif name == "constant_trace":
        bound = s.trace
    elif name == "efra":
        bound = n * _efra_bound(s)
    else:
        # each pivot of P = U D Uᵀ is capped at P_max (exact); the trace
        # Σ D_j |U e_j|² then stays within a small multiple of n·P_max
        assert np.max(ud(est.P)[1]) <= opts["P_max"] * (1 + 1e-9)
        bound = 2 * n * opts["P_max"]
    assert np.all(traces <= bound * (1 + 1e-9)), (traces.max(), bound)
    # the same strategy on a stream excited all along
    rng2 = np.random.default_rng(1)
    Phi_e = rng2.standard_normal((20_000, 2))
    y_e = Phi_e @ THETA_A + 0.01 * rng2.standard_normal(20_000)
    ref = adaptid.RLS(2, P0=1.0, **opts)
    ref.run(Phi_e, y_e, store=False)
    ref_track = ref.run(Phi_j, y_j).theta
    d, d_ref = _delay(track, THETA_B), _delay(ref_track, THETA_B)
    assert d_ref < 400
    assert d <= 1.25 * d_ref + 10, (d, d_ref)


def test_excitation_measure(rng):
    est = adaptid.SlidingWindowRLS(2, 100, P0=1e6)
    Phi = rng.standard_normal((400, 2))
    est.run(Phi, Phi @ [1.0, 1.0])
    R = Phi[-100:].T @ Phi[-100:]
    np.testing.assert_allclose(est.excitation, np.linalg.eigvalsh(R)[0], rtol=1e-6)
    quiet = Phi.copy()
    quiet[:, 1] = 0.0
    est.run(quiet, quiet @ [1.0, 1.0])
    assert est.excitation < 1e-5  # only the decayed prior 1/P0 remains in φ₂


@pytest.mark.parametrize("form", FORMS)
def test_windup_threshold_warns_once_per_episode(rng, form):
    # U-D: the pivot D₂ = P₂₂ here; square-root and covariance forms: diag(P)
    Phi = np.column_stack([rng.standard_normal(2000), np.zeros(2000)])
    est = adaptid.RLS(2, forgetting=0.99, P0=1.0, windup_threshold=1e3, form=form)
    with pytest.warns(adaptid.CovarianceWindupWarning, match="windup_threshold=1e\\+03") as rec:
        est.run(Phi[:1000], Phi[:1000, 0])
        est.run(Phi[1000:], Phi[1000:, 0])
    assert len(rec) == 1
    # 0.99^-k passes 1e3 at k = ln(1e3)/-ln(0.99) ≈ 688
    est2 = adaptid.RLS(2, forgetting=0.99, P0=1.0, windup_threshold=1e3, form=form)
    with warnings.catch_warnings(record=True) as rec2:
        warnings.simplefilter("always")
        est2.run(Phi[:680], Phi[:680, 0])
    assert not rec2
    est.reset()
    with pytest.warns(adaptid.CovarianceWindupWarning):
        est.run(Phi, Phi[:, 0])


def test_kalman_windup_threshold(rng):
    Phi = np.column_stack([rng.standard_normal(500), np.zeros(500)])
    est = adaptid.KalmanRLS(2, process_cov=1.0, P0=1.0, windup_threshold=100.0)
    with pytest.warns(adaptid.CovarianceWindupWarning):
        est.run(Phi, Phi[:, 0])


# --------------------------------------------------------------------------
# long run: 10⁶ (CI) / 10⁷ (soak) updates at λ = 0.99
# --------------------------------------------------------------------------
def _long_run(n_total, rng, form="ud"):
    n, lam, W = 4, 0.99, 4000          # λ^W = 3e-18: older samples are below 1e-8
    est = adaptid.RLS(n, forgetting=lam, P0=1e4, form=form)
    chunk = 100_000
    theta = np.array([1.0, -2.0, 0.5, 3.0])
    for start in range(0, n_total, chunk):
        Phi = rng.standard_normal((chunk, n))
        y = Phi @ theta + 0.1 * rng.standard_normal(chunk)
        est.run(Phi, y, store=False)
        P = est.P
        assert np.array_equal(P, P.T) and np.linalg.eigvalsh(P)[0] > 0
        wts = lam ** np.arange(W - 1, -1, -1.0)
        sw = np.sqrt(wts)
        ref = np.linalg.lstsq(Phi[-W:] * sw[:, None], y[-W:] * sw, rcond=None)[0]
        np.testing.assert_allclose(est.theta, ref, rtol=0, atol=1e-8)
        info = (Phi[-W:] * wts[:, None]).T @ Phi[-W:]
        np.testing.assert_allclose(P @ info, np.eye(n), atol=1e-8)
    assert est.n_updates == n_total


@pytest.mark.parametrize("form", FORMS)
def test_long_run_million_updates_stay_exact(rng, form):
    _long_run(1_000_000, rng, form)


@pytest.mark.soak
@pytest.mark.parametrize("form", FORMS)
def test_long_run_ten_million_updates_stay_exact(rng, form):
    _long_run(10_000_000, rng, form)


# --------------------------------------------------------------------------
# missing data: 5 % NaN
# --------------------------------------------------------------------------
@pytest.mark.parametrize("form", FORMS)
def test_nan_skip_equals_removed_samples_rls(rng, form):
    N, n = 4000, 4  # n of _long_run: one compilation per form for both
    Phi = rng.standard_normal((N, n))
    y = Phi @ [1.0, 2.0, -1.0, 0.5] + 0.1 * rng.standard_normal(N)
    miss = rng.random(N) < 0.05
    Phi_nan, y_nan = Phi.copy(), y.copy()
    half = miss & (rng.random(N) < 0.5)
    Phi_nan[half, rng.integers(0, n, half.sum())] = np.nan
    y_nan[miss & ~half] = np.nan
    est = adaptid.RLS(n, P0=1e3, nan_policy="skip", form=form)
    tr = est.run(Phi_nan, y_nan)
    ref = adaptid.RLS(n, P0=1e3, form=form)
    tr_ref = ref.run(Phi[~miss], y[~miss])
    assert np.array_equal(tr.skipped, miss) and est.n_skipped == miss.sum()
    np.testing.assert_allclose(tr.theta[~miss], tr_ref.theta, rtol=1e-12)
    assert np.all(np.isnan(tr.error[miss]))
    np.testing.assert_allclose(est.theta, ref.theta, rtol=1e-12)


def test_nan_skip_kalman_equals_filterpy_skipping_updates(rng):
    from filterpy.kalman import KalmanFilter
    N, n = 2000, 2
    Phi = rng.standard_normal((N, n))
    y = Phi @ [1.0, -1.0] + 0.1 * rng.standard_normal(N)
    miss = rng.random(N) < 0.05
    y[miss] = np.nan
    q, r = 1e-4, 0.01
    est = adaptid.KalmanRLS(n, process_cov=q, noise_var=r, P0=10.0, nan_policy="skip")
    tr = est.run(Phi, y)
    kf = KalmanFilter(dim_x=n, dim_z=1)
    kf.x = np.zeros((n, 1))
    kf.P = np.eye(n) * 10.0
    kf.F = np.eye(n)
    kf.Q = np.eye(n) * q
    kf.R = np.array([[r]])
    for k in range(N):
        if not miss[k]:
            kf.H = Phi[k][None, :]
            kf.update(np.array([[y[k]]]))
        kf.predict()  # a missing sample: time update only
        np.testing.assert_allclose(tr.theta[k], kf.x[:, 0], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(est.P, kf.P, rtol=1e-9)
    assert np.array_equal(tr.skipped, miss)


def test_efra_refuses_a_prior_outside_its_bounds():
    s = fg.EFRA(0.5, 0.005, 0.005, 0.95)
    bound = (1 - s.alpha) / (s.lam * s.delta)
    with pytest.raises(ValueError, match="P0 must be with eigenvalues <= "):
        adaptid.RLS(2, forgetting=s, P0=1e4)
    adaptid.RLS(2, forgetting=s, P0=0.99 * bound)


def test_anti_windup_example_runs():
    import subprocess
    import sys
    from pathlib import Path
    script = Path(__file__).resolve().parents[1] / "examples" / "anti_windup.py"
    out = subprocess.run([sys.executable, str(script), "--quiet-steps", "3000", "--no-plot"],
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    rows = {line[:26].strip(): line[26:].split() for line in out.stdout.splitlines()[1:]}
    assert rows["exponential λ=0.98"][1] == "True"      # windup warned
    for name in ("directional λ=0.98", "constant trace", "EFRA", "exponential + P_max=10"):
        assert rows[name][1] == "False", (name, rows[name])

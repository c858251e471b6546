"""RLS in its three forms: U-D (Bierman), square root (Potter) and covariance (issue 19).

Oracles:
* numpy.linalg.lstsq of the exponentially weighted, ridge-augmented problem
  (the RLS criterion of the RLS docstring, solved in batch: rows √(λ^{N-k} w_k)·φ_k
  and the prior's rows √(λ^N/P0)·I with target 0);
* the information matrix Σ λ^{N-k} w_k φ_k φ_kᵀ + λ^N/P0·I formed from the data,
  whose product with P must be I;
* the U-D form itself only where a property is structural (update == run,
  batched == per stream, segments == per segment, state round trips bit for bit)
  or a conversion must return what it was given.
Tolerances: the problems are well conditioned (Gaussian regressors, N ≫ n), so
the recursion agrees with lstsq to a few hundred ε of |θ| (atol 1e-9 with |θ| ~ 1).
"""

import warnings

import numpy as np
import pytest

import adaptid
from adaptid.estimators._rlsforms import AUTO_SQRT_ABOVE

FORMS = ("ud", "sqrt", "covariance")


def _data(rng, N, n, noise=0.1):
    Phi = rng.standard_normal((N, n))
    theta = rng.standard_normal(n)
    return Phi, Phi @ theta + noise * rng.standard_normal(N)


def _lstsq(Phi, y, lam, w, P0):
    """argmin Σ λ^{N-k} w_k (y_k − φ_kᵀθ)² + λ^N θᵀθ/P0, and its information matrix."""
    N, n = Phi.shape
    g = lam ** np.arange(N - 1, -1, -1.0) * w
    A = np.vstack([Phi * np.sqrt(g)[:, None], np.sqrt(lam ** N / P0) * np.eye(n)])
    b = np.concatenate([y * np.sqrt(g), np.zeros(n)])
    return np.linalg.lstsq(A, b, rcond=None)[0], A.T @ A


CASES = {"plain": (1.0, False), "forgetting": (0.995, False), "weights": (0.998, True)}


@pytest.mark.parametrize("case", sorted(CASES))
@pytest.mark.parametrize("n", [2, 5, 24, 33])
@pytest.mark.parametrize("form", FORMS)
def test_every_form_equals_weighted_ridge_lstsq(rng, form, n, case):
    lam, weighted = CASES[case]
    N, P0 = 3000, 1e8
    Phi, y = _data(rng, N, n)
    w = rng.uniform(0.2, 3.0, N) if weighted else np.ones(N)
    ref, info = _lstsq(Phi, y, lam, w, P0)
    est = adaptid.RLS(n, forgetting=lam, P0=P0, form=form)
    est.run(Phi, y, weights=w if weighted else None, store=False)
    assert est.form == form
    np.testing.assert_allclose(est.theta, ref, rtol=0, atol=1e-9)
    P = est.P
    assert np.array_equal(P, P.T)
    np.testing.assert_allclose(P @ info, np.eye(n), atol=1e-7)


@pytest.mark.parametrize("n", [5, 24])
@pytest.mark.parametrize("form", FORMS)
def test_update_equals_run_bitwise_with_weights_zero_weights_and_skips(rng, form, n):
    N = 200
    Phi, y = _data(rng, N, n)
    w = rng.uniform(0.5, 2.0, N)
    w[::17] = 0.0
    Phi[5::23, n - 1] = np.nan
    y[11::29] = np.inf
    lam = rng.uniform(0.95, 1.0, N)
    a = adaptid.RLS(n, P0=100.0, nan_policy="skip", form=form)
    b = adaptid.RLS(n, P0=100.0, nan_policy="skip", form=form)
    tr = a.run(Phi, y, weights=w, forgetting=lam)
    errs = np.array([b.update(Phi[k], y[k], weight=w[k], forgetting=lam[k]) for k in range(N)])
    assert np.array_equal(a.get_state()["state"], b.get_state()["state"])
    assert np.array_equal(tr.error, errs, equal_nan=True)
    assert a.n_skipped == b.n_skipped > 0
    # a run in two pieces is the run in one
    c = adaptid.RLS(n, P0=100.0, nan_policy="skip", form=form)
    c.run(Phi[:77], y[:77], weights=w[:77], forgetting=lam[:77])
    c.run(Phi[77:], y[77:], weights=w[77:], forgetting=lam[77:])
    assert np.array_equal(a.get_state()["state"], c.get_state()["state"])


@pytest.mark.parametrize("n", [2])
@pytest.mark.parametrize("form", FORMS)
def test_batched_and_segments_equal_per_stream_runs(rng, form, n):
    B, N = 3, 120
    Phi = rng.standard_normal((B, N, n))
    y = Phi.sum(axis=2) + 0.1 * rng.standard_normal((B, N))
    est = adaptid.RLS(n, forgetting=0.99, P0=10.0, form=form)
    tb = est.run_batched(Phi, y)
    off = np.array([0, 50, 50, 170, 3 * N])
    seg = est.copy().run_segments(Phi.reshape(-1, n), y.ravel(), off, store=True)
    for b in range(B):
        one = adaptid.RLS(n, forgetting=0.99, P0=10.0, form=form)
        t1 = one.run(Phi[b], y[b])
        assert np.array_equal(tb.theta[b], t1.theta)
        # the kernels' states bit for bit (P itself is formed by NumPy, whose
        # stacked and single matmuls may round differently). Square-root form: in the
        # full suite (never alone) its final S has differed from the single run's by up
        # to 51 ulp while every θ above was equal; not explained yet, so rtol 1e-12 there.
        sb, s1 = est.get_state()["state"][b], one.get_state()["state"]
        if form == "sqrt":
            np.testing.assert_allclose(sb, s1, rtol=1e-12, atol=0)
        else:
            assert np.array_equal(sb, s1)
    for g in range(len(off) - 1):
        one = adaptid.RLS(n, forgetting=0.99, P0=10.0, form=form)
        one.run(Phi.reshape(-1, n)[off[g]:off[g + 1]], y.ravel()[off[g]:off[g + 1]])
        assert np.array_equal(seg.theta[g], one.theta)
        np.testing.assert_allclose(seg.P[g], one.P, rtol=1e-14, atol=0)


@pytest.mark.parametrize("form", FORMS)
def test_state_and_state_file_round_trips_are_exact(rng, form, tmp_path):
    n = 5
    Phi, y = _data(rng, 300, n)
    est = adaptid.RLS(n, forgetting=0.99, P0=50.0, form=form)
    est.run(Phi[:200], y[:200])
    st = est.get_state()
    assert st["options"]["form"] == form
    back = adaptid.RLS.from_state(st)
    est.save_state(tmp_path / "s.npz")
    loaded = adaptid.RLS.load_state(tmp_path / "s.npz")
    for other in (back, loaded):
        assert other.form == form
        assert np.array_equal(other.get_state()["state"], st["state"])
        assert np.array_equal(other.run(Phi[200:], y[200:]).theta,
                              est.copy().run(Phi[200:], y[200:]).theta)


def test_state_files_written_before_forms_load_as_ud():
    from pathlib import Path
    path = Path(__file__).resolve().parents[1] / "data" / "state_format2" / "rls.npz"
    est = adaptid.load_state(path)
    assert est.form == "ud"
    n = est.n_params
    assert "form" in est.get_state()["options"]
    # n of the stored file is small: "auto" would also give U-D; the explicit "ud"
    # matters for n > AUTO_SQRT_ABOVE (checked with a synthetic old state below)
    assert n <= 16


def test_old_state_dict_without_form_at_large_n_is_read_as_ud(rng):
    n = 24
    Phi, y = _data(rng, 100, n)
    est = adaptid.RLS(n, P0=10.0, form="ud")
    est.run(Phi, y)
    st = est.get_state()
    del st["options"]["form"]
    back = adaptid.RLS.from_state(st)
    assert back.form == "ud"
    np.testing.assert_array_equal(back.P, est.P)


@pytest.mark.parametrize("n", [5, 24])
@pytest.mark.parametrize("form", ("sqrt", "covariance"))
def test_conversion_from_ud_and_back_is_exact_up_to_rounding(rng, form, n):
    Phi, y = _data(rng, 400, n)
    ud = adaptid.RLS(n, forgetting=0.99, P0=1e3, form="ud")
    ud.run(Phi[:300], y[:300])
    st = ud.get_state()
    other = adaptid.RLS.from_state(st, form=form)
    assert other.form == form
    np.testing.assert_array_equal(other.theta, ud.theta)
    scale = np.abs(ud.P).max()
    np.testing.assert_allclose(other.P, ud.P, rtol=0, atol=1e-13 * scale)
    back = adaptid.RLS.from_state(other.get_state(), form="ud")
    U0, D0 = ud._ud_views(ud._S)
    U1, D1 = back._ud_views(back._S)
    np.testing.assert_allclose(D1, D0, rtol=1e-12)
    np.testing.assert_allclose(U1, U0, rtol=0, atol=1e-12 * np.abs(U0).max())
    assert np.array_equal(np.tril(U1, -1), np.zeros((n, n))) and np.all(np.diag(U1) == 1.0)
    # both continue to the same estimate (the batch oracle for the rest of the data)
    t_other = other.run(Phi[300:], y[300:]).theta
    t_ud = ud.run(Phi[300:], y[300:]).theta
    np.testing.assert_allclose(t_other, t_ud, rtol=0, atol=1e-10)


def test_sqrt_to_covariance_and_kernel_settings_give_the_ud_factors(rng):
    n = 5
    Phi, y = _data(rng, 200, n)
    s = adaptid.RLS(n, forgetting=0.98, P0=10.0, form="sqrt")
    s.run(Phi, y)
    c = adaptid.RLS.from_state(s.get_state(), form="covariance")
    np.testing.assert_allclose(c.P, s.P, rtol=0, atol=1e-13 * np.abs(s.P).max())
    ks = s.kernel_settings()
    P_ud = ks.U @ np.diag(ks.D) @ ks.U.T
    np.testing.assert_allclose(P_ud, s.P, rtol=0, atol=1e-13 * np.abs(s.P).max())


def test_form_validation_and_auto():
    with pytest.raises(ValueError, match="form must be one of"):
        adaptid.RLS(3, form="qr")
    with pytest.raises(ValueError, match="form must be 'ud' or 'auto'"):
        adaptid.RLS(3, forgetting=adaptid.forgetting.Directional(0.98), form="sqrt")
    with pytest.raises(ValueError, match="form must be 'ud' or 'auto'"):
        adaptid.RLS(3, forgetting=0.98, P_max=10.0, form="covariance")
    assert adaptid.RLS(3, P_max=10.0).form == "ud"
    assert AUTO_SQRT_ABOVE == 15                     # the measured crossover (_rlsforms)
    assert adaptid.RLS(15).form == "ud"
    assert adaptid.RLS(16).form == "sqrt"
    assert adaptid.RLS(16, P0="diffuse").form == "ud"  # the diffuse start hands over to U-D
    assert adaptid.RLS(16, P_max=10.0).form == "ud"
    assert adaptid.estimator("rls", 3, form="covariance").form == "covariance"


def _unexcited(rng, N=300):
    u = rng.standard_normal(N)
    Phi = np.column_stack([u, u])  # (1, 1) excited, (1, −1) never
    return Phi, Phi @ [1.0, 2.0]


def test_covariance_form_repairs_a_lost_definiteness_and_warns(rng):
    # λ = 0.5: P grows like 2^k along (1, −1) while it shrinks along (1, 1); past
    # a ratio of 1/ε the rank-one update leaves φᵀPφ ≤ 0 in floating point
    Phi, y = _unexcited(rng)
    est = adaptid.RLS(2, forgetting=0.5, P0=1.0, windup_threshold=np.inf, form="covariance")
    with pytest.warns(adaptid.DefinitenessLossWarning, match="repaired"):
        tr = est.run(Phi, y)
    assert np.all(np.isfinite(tr.theta)) and np.all(np.isfinite(est.P))
    # the excited combination θ₁ + θ₂ = 3 is still identified
    assert abs(est.theta.sum() - 3.0) < 1e-8
    assert np.all(np.diag(est.P) > 0)
    # update (one sample at a time) warns the same way
    one = adaptid.RLS(2, forgetting=0.5, P0=1.0, windup_threshold=np.inf, form="covariance")
    with pytest.warns(adaptid.DefinitenessLossWarning):
        for k in range(Phi.shape[0]):
            one.update(Phi[k], y[k])
    assert np.array_equal(one.get_state()["state"], est.get_state()["state"])


def test_covariance_form_repair_in_batched_and_segments_warns(rng):
    Phi, y = _unexcited(rng)
    est = adaptid.RLS(2, forgetting=0.5, P0=1.0, windup_threshold=np.inf, form="covariance")
    with pytest.warns(adaptid.DefinitenessLossWarning, match="stream"):
        est.run_batched(np.stack([Phi, Phi]), np.stack([y, y]))
    est.reset()
    with pytest.warns(adaptid.DefinitenessLossWarning, match="segment"):
        res = est.run_segments(Phi, y, [0, 10, Phi.shape[0]])
    assert np.all(np.isfinite(res.theta))


@pytest.mark.parametrize("n", [8, 13, 33])
def test_covariance_vector_sweep_monitor_is_the_rule(rng, n):
    """n in the range of the vector sweep (5..VECTOR_SWEEP_MAX, _kernels/toolchain/_covsweep.py:
    33 is in it except on AMD Zen), a full block and blocks with a rest: the
    windup sample the kernel reports is the rule's,
    evaluated in NumPy on P after every update()."""
    N = 600
    Phi = rng.standard_normal((N, n))
    Phi[:, -1] *= (np.arange(N) % 300) < 30  # the last regressor excited in bursts
    y = Phi @ rng.standard_normal(n)
    thr = 20.0
    one = adaptid.RLS(n, forgetting=0.97, P0=1.0, windup_threshold=thr, form="covariance")
    k_rule = None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", adaptid.CovarianceWindupWarning)
        for k in range(N):
            one.update(Phi[k], y[k])
            dg = np.diag(one.P)
            if not np.all((dg > 0) & (dg < thr)):
                k_rule = k
                break
    assert k_rule is not None and k_rule > 30
    est = adaptid.RLS(n, forgetting=0.97, P0=1.0, windup_threshold=thr, form="covariance")
    with pytest.warns(adaptid.CovarianceWindupWarning, match=f"at sample {k_rule}:"):
        est.run(Phi, y)
    # and the run is the updates, bit for bit, up to there
    part = adaptid.RLS(n, forgetting=0.97, P0=1.0, windup_threshold=thr, form="covariance")
    with pytest.warns(adaptid.CovarianceWindupWarning):
        part.run(Phi[:k_rule + 1], y[:k_rule + 1])
    assert np.array_equal(part.P, one.P) and np.array_equal(part.theta, one.theta)


@pytest.mark.parametrize("form", ("ud", "sqrt"))
def test_factored_forms_need_no_repair_on_the_same_data(rng, form):
    Phi, y = _unexcited(rng)
    est = adaptid.RLS(2, forgetting=0.5, P0=1.0, windup_threshold=np.inf, form=form)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        tr = est.run(Phi, y)
    assert np.all(np.isfinite(tr.theta))
    assert abs(est.theta.sum() - 3.0) < 1e-6


def _first_outside(Phi, y, w, lam, thr, n):
    """The monitor's rule evaluated in NumPy on the state after every update():
    the first sample after which a diagonal entry of P = S Sᵀ left (0, thr)."""
    est = adaptid.RLS(n, P0=1.0, windup_threshold=thr, form="sqrt")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", adaptid.CovarianceWindupWarning)
        for k in range(Phi.shape[0]):
            est.update(Phi[k], y[k], weight=w[k], forgetting=lam[k])
            S = _cols_of(est.get_state()["state"][n:], n)
            dg = np.sum(S * S, axis=1)
            if not np.all((dg > 0) & (dg < thr)):
                return k
    return None


def _cols_of(block, n):
    return block[: n * n].reshape(n, n).T


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("n", [2, 24, 33])
def test_sqrt_monitor_code_is_the_exact_rule_sample_by_sample(n, seed):
    # The square-root kernel screens diag(P) with O(1) bounds and evaluates the rule
    # (diag(S Sᵀ) in (0, windup_threshold)) only when they cannot decide: the sample it
    # reports must be the rule's, here evaluated in NumPy after every step. One direction
    # is excited only in bursts, so diag(P) grows like λ^-k in between and crosses the
    # threshold at a sample the bounds must not miss nor anticipate.
    rng = np.random.default_rng([seed, n])
    N = 1500
    Phi = rng.standard_normal((N, n))
    Phi[:, -1] *= (np.arange(N) % 400) < 40  # bursts of excitation of the last regressor
    y = Phi @ rng.standard_normal(n)
    w = rng.uniform(0.5, 2.0, N)
    w[::37] = 0.0
    lam = rng.uniform(0.95, 0.99, N)
    # a threshold the last diagonal entry of P passes inside the first quiet stretch
    thr = float(rng.uniform(5.0, 50.0))
    k = _first_outside(Phi, y, w, lam, thr, n)
    assert k is not None and k > 40
    est = adaptid.RLS(n, P0=1.0, windup_threshold=thr, form="sqrt")
    with pytest.warns(adaptid.CovarianceWindupWarning, match=f"at sample {k}:"):
        est.run(Phi, y, weights=w, forgetting=lam)
    # and no warning when the same data stop one sample earlier
    quiet = adaptid.RLS(n, P0=1.0, windup_threshold=thr, form="sqrt")
    with warnings.catch_warnings():
        warnings.simplefilter("error", adaptid.CovarianceWindupWarning)
        quiet.run(Phi[:k], y[:k], weights=w[:k], forgetting=lam[:k])


def test_auto_switch_rule_when_a_threshold_is_set(monkeypatch):
    # the rule of resolve_form as documented in estimators/_rlsforms.py: "auto" is the
    # square-root form strictly above AUTO_SQRT_ABOVE up to FORMS_SPECIALISED_N, except with a forgetting strategy /
    # P_max (not fast) or an exact diffuse start (both need the U-D factors)
    from adaptid.estimators import _rlsforms as rf
    monkeypatch.setattr(rf, "AUTO_SQRT_ABOVE", 15)
    assert rf.resolve_form("auto", 16, True) == "sqrt"
    assert rf.resolve_form("auto", 15, True) == "ud"
    assert rf.resolve_form("auto", rf.FORMS_SPECIALISED_N, True) == "sqrt"
    assert rf.resolve_form("auto", rf.FORMS_SPECIALISED_N + 1, True) == "ud"  # both generic
    assert rf.resolve_form("auto", 40, True, diffuse=True) == "ud"
    assert rf.resolve_form("auto", 40, False) == "ud"
    assert rf.resolve_form("ud", 40, True) == "ud"
    monkeypatch.setattr(rf, "AUTO_SQRT_ABOVE", None)
    assert rf.resolve_form("auto", 64, True) == "ud"


def test_auto_square_root_estimator_runs_stats_in_ud_form(rng):
    """form="auto" above the switch runs in the square-root form; run(stats=True)
    continues in U-D form and gives what an explicit U-D estimator gives."""
    n, N = 24, 300
    Phi = rng.standard_normal((N, n))
    y = Phi @ np.ones(n) + rng.standard_normal(N)
    auto = adaptid.RLS(n, forgetting=0.99)
    assert auto.form == "sqrt"
    got = auto.run(Phi, y, stats=True)
    assert auto.form == "ud"
    ref = adaptid.RLS(n, forgetting=0.99, form="ud").run(Phi, y, stats=True)
    np.testing.assert_allclose(got.theta, ref.theta, rtol=1e-12, atol=0)
    np.testing.assert_allclose(got.stats.sigma2, ref.stats.sigma2, rtol=1e-12, equal_nan=True)
    with pytest.raises(ValueError, match="stats"):
        adaptid.RLS(n, forgetting=0.99, form="covariance").run(Phi, y, stats=True)


NO_JIT_RUN = """
import json, sys, numpy as np, adaptid
n, form = int(sys.argv[1]), sys.argv[2]
rng = np.random.default_rng(n)
Phi = rng.standard_normal((40, n)); y = Phi @ np.arange(1.0, n + 1.0) + 0.1 * rng.standard_normal(40)
est = adaptid.RLS(n, forgetting=0.99, form=form)
est.run(Phi, y)
print(json.dumps(list(est.theta)))
"""


@pytest.mark.parametrize("n", [3, 16])
@pytest.mark.parametrize("form", ["ud", "sqrt", "covariance"])
def test_every_form_runs_as_plain_python(n, form):
    """With NUMBA_DISABLE_JIT=1 (coverage of the kernels' source) every form runs the
    Python source of its kernel, whose compiled versions use vector IR for some n:
    same θ as the compiled run up to rounding (no FMA contraction in Python)."""
    import json
    import os
    import subprocess
    import sys
    env = dict(os.environ, NUMBA_DISABLE_JIT="1")
    proc = subprocess.run([sys.executable, "-c", NO_JIT_RUN, str(n), form], env=env,
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    plain = np.array(json.loads(proc.stdout.splitlines()[-1]))
    rng = np.random.default_rng(n)
    Phi = rng.standard_normal((40, n))
    y = Phi @ np.arange(1.0, n + 1.0) + 0.1 * rng.standard_normal(40)
    est = adaptid.RLS(n, forgetting=0.99, form=form)
    est.run(Phi, y)
    np.testing.assert_allclose(plain, est.theta, rtol=1e-9, atol=1e-12)

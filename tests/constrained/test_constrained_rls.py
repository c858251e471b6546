"""ConstrainedRLS: recursive least squares subject to Cθ = d.

Oracle: the batch constrained least-squares problem on the data so far,
with the prior written as extra rows (‖L⁻¹(θ − θ₀)‖², P₀ = L Lᵀ) and the
forgetting as row weights, solved at every step by constrained_lstsq (whose
own oracles are in test_constrained.py), plus scipy's null-space formula.
"""

import numpy as np
import pytest
import scipy.linalg as sla

from adaptid.constrained import ConstrainedRLS, constrained_lstsq


def problem(seed=0, n=5, p=2, N=40):
    rng = np.random.default_rng(seed)
    C = rng.standard_normal((p, n))
    d = rng.standard_normal(p)
    Phi = rng.standard_normal((N, n))
    y = Phi @ rng.standard_normal(n) + 0.1 * rng.standard_normal(N)
    return C, d, Phi, y


def batch_solution(Phi, y, C, d, theta0, P0, lam=1.0, w=None):
    """Exact minimiser of the RLS cost on the first k samples, on Cθ = d."""
    k = Phi.shape[0]
    w = np.ones(k) if w is None else w
    decay = np.sqrt(lam ** (k - 1 - np.arange(k)) * w)
    Linv = sla.solve_triangular(np.linalg.cholesky(P0), np.eye(len(theta0)), lower=True)
    A = np.vstack([decay[:, None] * Phi, np.sqrt(lam**k) * Linv])
    b = np.concatenate([decay * y, np.sqrt(lam**k) * Linv @ theta0])
    return constrained_lstsq(A, b, C, d).x


@pytest.mark.parametrize("lam, weighted", [(1.0, False), (0.93, False), (0.97, True)])
def test_equals_batch_constrained_lstsq_at_every_step(lam, weighted):
    C, d, Phi, y = problem()
    n = Phi.shape[1]
    rng = np.random.default_rng(1)
    theta0 = rng.standard_normal(n)                     # not on the affine set
    P0 = np.diag(rng.uniform(0.5, 5.0, n))
    w = rng.uniform(0.2, 2.0, Phi.shape[0]) if weighted else None
    est = ConstrainedRLS(n, C, d, theta0=theta0, P0=P0, forgetting=lam)
    traj = est.run(Phi, y, weights=w)
    for k in range(1, Phi.shape[0] + 1):
        ref = batch_solution(Phi[:k], y[:k], C, d, theta0, P0, lam,
                             None if w is None else w[:k])
        # both exact; the U-D RLS accumulates a few ulps per step on O(1)
        # quantities (1e-15 observed after 40 steps)
        np.testing.assert_allclose(traj.theta[k - 1], ref, rtol=0, atol=1e-10)
        assert np.max(np.abs(C @ traj.theta[k - 1] - d)) < 1e-12
    # a-priori errors ε_k = y_k − φ_kᵀθ_{k−1}
    prev = np.vstack([batch_solution(Phi[:0], y[:0], C, d, theta0, P0), traj.theta[:-1]])
    np.testing.assert_allclose(traj.error, y - np.einsum("ki,ki->k", Phi, prev), atol=1e-10)


def test_covariance_is_the_inverse_hessian_on_the_null_space():
    C, d, Phi, y = problem(2)
    n = Phi.shape[1]
    P0 = 2.0
    est = ConstrainedRLS(n, C, d, P0=P0)
    est.run(Phi, y)
    N = sla.null_space(C)
    H = N.T @ (Phi.T @ Phi + np.eye(n) / P0) @ N        # half Hessian on z
    ref = N @ np.linalg.solve(H, N.T)                    # basis-independent
    # O(1/N) entries, U-D propagation: ~1e-16 absolute
    np.testing.assert_allclose(est.P, ref, atol=1e-12)
    assert np.max(np.abs(C @ est.P)) < 1e-14


def test_diffuse_prior_gives_the_constrained_least_squares_fit():
    C, d, Phi, y = problem(3)
    est = ConstrainedRLS(5, C, d, P0=1e12)
    est.run(Phi, y)
    ref = constrained_lstsq(Phi, y, C, d).x
    # prior weight 1e-12 against a data Hessian O(40): relative bias ~1e-13
    np.testing.assert_allclose(est.theta, ref, atol=1e-9)


def test_run_equals_updates_bit_for_bit_and_resumes_from_state():
    C, d, Phi, y = problem(4)
    est = ConstrainedRLS(5, C, d, forgetting=0.98)
    traj = est.run(Phi, y)
    one = ConstrainedRLS(5, C, d, forgetting=0.98)
    errs = [one.update(Phi[k], y[k]) for k in range(Phi.shape[0])]
    np.testing.assert_array_equal(one.theta, est.theta)
    np.testing.assert_array_equal(np.array(errs), traj.error)
    np.testing.assert_array_equal(traj.theta[-1], est.theta)
    # stop half way, save, rebuild, continue
    first = ConstrainedRLS(5, C, d, forgetting=0.98)
    first.run(Phi[:17], y[:17])
    resumed = ConstrainedRLS.from_state(first.get_state())
    resumed.run(Phi[17:], y[17:])
    np.testing.assert_array_equal(resumed.theta, est.theta)
    np.testing.assert_array_equal(resumed.P, est.P)
    assert resumed.n_updates == est.n_updates == Phi.shape[0]
    dup = est.copy()
    dup.update(Phi[0], 100.0)
    assert not np.array_equal(dup.theta, est.theta)      # independent copy
    est.reset()
    assert est.n_updates == 0
    np.testing.assert_allclose(C @ est.theta, d, atol=1e-14)


def test_prior_mean_is_projected_onto_the_constraints():
    # No data: θ minimises (θ − θ₀)ᵀP₀⁻¹(θ − θ₀) on Cθ = d.
    C, d, _, _ = problem(5)
    rng = np.random.default_rng(5)
    theta0 = rng.standard_normal(5)
    P0 = np.diag([1.0, 2.0, 3.0, 4.0, 5.0])
    est = ConstrainedRLS(5, C, d, theta0=theta0, P0=P0)
    # closed form: θ = θ₀ − P₀Cᵀ(CP₀Cᵀ)⁻¹(Cθ₀ − d)
    ref = theta0 - P0 @ C.T @ np.linalg.solve(C @ P0 @ C.T, C @ theta0 - d)
    np.testing.assert_allclose(est.theta, ref, atol=1e-13)  # O(1) values


def test_nan_policy_skip_and_raise():
    C, d, Phi, y = problem(6)
    y_bad = y.copy()
    y_bad[5] = np.nan
    est = ConstrainedRLS(5, C, d, nan_policy="skip")
    traj = est.run(Phi, y_bad)
    ref = ConstrainedRLS(5, C, d)
    ref.run(np.delete(Phi, 5, axis=0), np.delete(y, 5))
    np.testing.assert_allclose(est.theta, ref.theta, atol=1e-13)
    assert traj.skipped[5] and est.n_skipped == 1
    strict = ConstrainedRLS(5, C, d)
    strict.run(Phi[:3], y[:3])
    before = strict.get_state()
    with pytest.raises(ValueError, match=r"^phi must be finite"):
        strict.update(np.array([1.0, np.nan, 0, 0, 0]), 1.0)
    with pytest.raises(ValueError, match=r"^y must be finite"):
        strict.run(Phi[:2], [1.0, np.inf])
    after = strict.get_state()
    np.testing.assert_array_equal(after["inner"]["state"], before["inner"]["state"])


def test_run_batched_equals_separate_streams():
    C, d, Phi, y = problem(7)
    rng = np.random.default_rng(7)
    Phis = np.stack([Phi, rng.standard_normal(Phi.shape)])
    ys = np.stack([y, rng.standard_normal(y.shape)])
    est = ConstrainedRLS(5, C, d)
    traj = est.run_batched(Phis, ys)
    assert traj.theta.shape == (2, Phi.shape[0], 5) and est.theta.shape == (2, 5)
    for b in range(2):
        one = ConstrainedRLS(5, C, d)
        one.run(Phis[b], ys[b])
        np.testing.assert_allclose(est.theta[b], one.theta, atol=1e-13)  # same kernel
    assert est.predict(np.ones((2, 5))).shape == (2,)


@pytest.mark.parametrize("args, kwargs, exc, pattern", [
    ((5, np.ones((2, 4)), np.ones(2)), {}, ValueError, r"^C must be of shape \(p, 5\)"),
    ((5, np.ones((2, 5)), np.ones(2)), {}, ValueError, r"^C must be of full row rank"),
    ((2, np.eye(2), np.ones(2)), {}, ValueError, r"^C must be of fewer rows than n_params"),
    ((5, np.eye(5)[:2], np.ones(3)), {}, ValueError, r"^d must be of shape \(2,\)"),
    ((5, np.eye(5)[:2], np.ones(2)), dict(forgetting=1.5), ValueError, r"^forgetting must be"),
    ((5, np.eye(5)[:2], np.ones(2)), dict(P0=-1.0), ValueError, r"^P0 must be"),
    ((5, np.eye(5)[:2], np.ones(2)), dict(theta0=np.ones(4)), ValueError, r"^theta0 must be"),
    ((0, np.eye(5)[:2], np.ones(2)), {}, ValueError, r"^n_params must be an integer >= 1"),
    ((5, [["a"] * 5], [1.0]), {}, TypeError, r"^C must be"),
])
def test_bad_construction(args, kwargs, exc, pattern):
    with pytest.raises(exc, match=pattern):
        ConstrainedRLS(*args, **kwargs)


def test_bad_updates_and_state():
    est = ConstrainedRLS(3, [[1.0, 1.0, 1.0]], [1.0])
    with pytest.raises(ValueError, match=r"^phi must be with last axis n_params=3"):
        est.update(np.ones(4), 1.0)
    with pytest.raises(ValueError, match=r"^y must be a scalar"):
        est.update(np.ones(3), [1.0, 2.0])
    with pytest.raises(ValueError, match=r"^y must be of shape \(2,\)"):
        est.run(np.ones((2, 3)), np.ones(3))
    with pytest.raises(TypeError, match=r"^state must be a dict"):
        ConstrainedRLS.from_state([1, 2])
    with pytest.raises(ValueError, match=r"^state must be the state of a ConstrainedRLS"):
        ConstrainedRLS.from_state({"estimator": "RLS"})
    assert repr(est).startswith("ConstrainedRLS(n_params=3, n_constraints=1")

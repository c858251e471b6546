"""Sliding window in the pseudo-linear recursions (ARMAX / OE / BJ with a
SlidingWindowRLS): a removal that would lose definiteness is replaced by an
exact re-solve of the window from a buffer of the regressors that were used,
as the core SlidingWindowRLS does (issue 16, point 5).

Oracle: the regressors the recursion used are rebuilt here, independently,
from its own trajectory (the simulated output w_k = φ_kᵀθ_k of OE, the
a-posteriori residual of ARMAX), which freezes the pseudo-linear signals; the
window estimate must then be the weighted least-squares solution on that
window plus the decayed prior, solved by numpy's lstsq on the stacked system.
"""

import warnings

import numpy as np
import pytest
from scipy.signal import lfilter

import adaptid
from adaptid.models import ARMAX, BJ, OE, arx_regressors


def _window_oracle(rows, Y, M, lam, P0, k):
    """argmin Σ_{j=k-M+1..k} λ^(k-j)(y_j − φ_jᵀθ)² + λ^(k+1) θᵀθ/P0 (θ₀ = 0), by lstsq."""
    n = rows.shape[1]
    lo = max(0, k - M + 1)
    sw = np.sqrt(lam ** (k - np.arange(lo, k + 1)))
    A = np.vstack([rows[lo:k + 1] * sw[:, None], np.sqrt(lam ** (k + 1) / P0) * np.eye(n)])
    b = np.r_[Y[lo:k + 1] * sw, np.zeros(n)]
    return np.linalg.lstsq(A, b, rcond=None)[0]


def _close(theta, ref, P0):
    """Equal within 10·P0·eps relative to the row's scale. The recursion works
    on P = (information)⁻¹ started at P0·I: while the data do not yet determine
    every direction (the first rows, a poorly excited window) each update
    cancels terms of size P0‖φ‖² down to O(1), so ~P0·eps relative is what any
    covariance-form RLS keeps (up to 2.6e-6 seen here for P0 = 1e10 with numba
    off, 8e-7 compiled with FMA); a refused removal instead leaves an O(1)
    error (an extra sample in the window)."""
    return np.max(np.abs(theta - ref)) <= 10 * P0 * np.finfo(float).eps * max(1.0, np.max(np.abs(ref)))


def _oe_rows_from_trajectory(Phi_fix, Th, nf):
    """OE(nb, nf) regressors rebuilt from the trajectory: φ_k = [u lags, −w_{k-1..k-nf}],
    w_k = φ_kᵀθ_k (a-posteriori simulated output, 0 before the first row)."""
    N, nb = Phi_fix.shape
    w = np.zeros(N)
    rows = np.zeros((N, nb + nf))
    for k in range(N):
        rows[k] = np.r_[Phi_fix[k], [-w[k - l] if k - l >= 0 else 0.0 for l in range(1, nf + 1)]]
        w[k] = rows[k] @ Th[k]
    return rows


def _silent_input(N, rng):
    # u is zero on samples 40..69: the window (M = 10) then holds no sample
    # that excites the b directions, and removing the last one that did would
    # leave P⁻¹ with only the 1e-10 prior there: 1 − c φᵀPφ ≈ 1/(1 + 1e10 φᵀφ)
    # < DOWNDATE_RTOL = 1e-8. The previous kernel (commit f66d1cc) refused
    # such a removal on this very record, for both λ below (checked by running
    # that commit: "1 window removal(s) refused: ..."), and went on with a
    # window that held older samples too.
    u = rng.standard_normal(N)
    u[40:70] = 0.0
    return u


@pytest.mark.parametrize("lam", [1.0, 0.97])
def test_oe_window_resolves_instead_of_refusing(rng, lam):
    N, M, P0 = 140, 10, 1e10
    u = _silent_input(N, rng)
    y = lfilter([0, 1.0, 0.5], [1, -0.6], u) + 0.05 * rng.standard_normal(N)
    est = adaptid.SlidingWindowRLS(3, M, P0=P0, forgetting=lam)
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        traj = OE(2, 1, 1).fit_recursive(y, u, est)
    msgs = [str(w.message) for w in rec]
    assert traj.n_rebuilds >= 1
    assert len(rec) == 1 and issubclass(rec[0].category, adaptid.DefinitenessLossWarning)
    assert "re-solved" in msgs[0] and not any("refused" in m for m in msgs)
    reg = arx_regressors(y, u, 0, 2, 1)
    rows = _oe_rows_from_trajectory(reg.Phi, traj.theta, 1)
    for k in range(rows.shape[0]):
        ref = _window_oracle(rows, reg.y, M, lam, P0, k)
        assert _close(traj.theta[k], ref, P0), k


def test_armax_window_resolve_matches_frozen_regressors(rng):
    N, M, P0 = 160, 12, 1e10
    u = _silent_input(N, rng)
    e = 0.1 * rng.standard_normal(N)
    y = lfilter([0, 1.0], [1, -0.5], u) + lfilter([1, 0.3], [1, -0.5], e)
    with pytest.warns(adaptid.DefinitenessLossWarning, match="re-solved"):
        traj = ARMAX(1, 1, 1, 1).fit_recursive(y, u, adaptid.SlidingWindowRLS(3, M, P0=P0))
    assert traj.n_rebuilds >= 1
    reg = arx_regressors(y, u, 1, 1, 1)
    Phi_fix = reg.Phi * np.array([-1.0, 1.0])
    # ARMAX(1,1,1): φ_k = [−y_{k-1}, u_{k-1}, ε_{k-1}], ε_k = y_k − φ_kᵀθ_k (a posteriori)
    Nr = Phi_fix.shape[0]
    rows = np.zeros((Nr, 3))
    eps = np.zeros(Nr)
    for k in range(Nr):
        rows[k] = np.r_[Phi_fix[k], eps[k - 1] if k else 0.0]
        eps[k] = reg.y[k] - rows[k] @ traj.theta[k]
    for k in range(Nr):
        ref = _window_oracle(rows, reg.y, M, 1.0, P0, k)
        assert _close(traj.theta[k], ref, P0), k


def test_window_without_rebuild_is_unchanged_and_silent(rng):
    # a well-excited window never re-solves and gives no warning (pytest turns
    # AdaptidWarning into errors, so a warning would fail this test)
    N, M = 300, 40
    u = rng.standard_normal(N)
    y = lfilter([0, 1.0, 0.5], [1, -0.6], u) + 0.05 * rng.standard_normal(N)
    traj = OE(2, 1, 1).fit_recursive(y, u, adaptid.SlidingWindowRLS(3, M, P0=1e4))
    assert traj.n_rebuilds == 0
    reg = arx_regressors(y, u, 0, 2, 1)
    rows = _oe_rows_from_trajectory(reg.Phi, traj.theta, 1)
    for k in (M - 1, 150, N - 3):
        np.testing.assert_allclose(traj.theta[k], _window_oracle(rows, reg.y, M, 1.0, 1e4, k),
                                   rtol=1e-8, atol=1e-10)


def test_bj_window_resolve_matches_frozen_regressors(rng):
    N, M, P0 = 160, 15, 1e10
    u = _silent_input(N, rng)
    e = 0.1 * rng.standard_normal(N)
    y = lfilter([0, 1.0, 0.5], [1, -0.6], u) + lfilter([1, 0.4], [1, -0.8], e)
    with pytest.warns(adaptid.DefinitenessLossWarning, match="re-solved"):
        traj = BJ(2, 1, 1, 1).fit_recursive(y, u, adaptid.SlidingWindowRLS(5, M, P0=P0))
    assert traj.n_rebuilds >= 1
    reg = arx_regressors(y, u, 0, 2, 1)
    # BJ(2,1,1,1): φ_k = [u_{k-1}, u_{k-2}, ε_{k-1}, −v_{k-1}, −w_{k-1}], with the
    # a-posteriori w_k = [u lags, −w_{k-1}]·[b, f]_k, v_k = y_k − w_k, ε_k = y_k − φ_kᵀθ_k
    Nr = reg.y.size
    rows = np.zeros((Nr, 5))
    w, v, eps = np.zeros(Nr), np.zeros(Nr), np.zeros(Nr)
    for k in range(Nr):
        p = (lambda x: x[k - 1] if k else 0.0)
        rows[k] = np.r_[reg.Phi[k], p(eps), -p(v), -p(w)]
        th = traj.theta[k]
        w[k] = rows[k, [0, 1, 4]] @ th[[0, 1, 4]]
        v[k] = reg.y[k] - w[k]
        eps[k] = reg.y[k] - rows[k] @ th
    for k in range(Nr):
        ref = _window_oracle(rows, reg.y, M, 1.0, P0, k)
        assert _close(traj.theta[k], ref, P0), k

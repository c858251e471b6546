"""Slow, obviously-correct oracles for the recursive estimators (tests only).

Each solves the defining cost directly as one stacked least-squares problem
with ``numpy.linalg.lstsq``; nothing here shares code with adaptid.
"""

import numpy as np


def _prior_rows(P0, theta0, weight):
    """Rows A, b with ||A θ - b||² = weight · (θ-θ0)ᵀ P0⁻¹ (θ-θ0)."""
    L = np.linalg.cholesky(P0)            # P0 = L Lᵀ  →  P0⁻¹ = L⁻ᵀ L⁻¹
    Linv = np.linalg.solve(L, np.eye(len(P0)))
    s = np.sqrt(weight)
    return s * Linv, s * (Linv @ theta0)


def rls_cost_minimiser(Phi, y, lam, w, theta0, P0, first=0):
    """argmin Σ_{k=first..N-1} (Π_{i=k+1..N-1} λ_i) w_k (y_k − φ_kᵀθ)² + (Π_{i=0..N-1} λ_i) prior.

    0-based: lam[i] is the forgetting applied at sample i. ``first`` > 0 restricts
    the data term to a window (the prior term is kept whole), as in TLSM.
    """
    N, n = Phi.shape
    y2 = y.reshape(N, -1)
    logl = np.log(lam)
    # Π_{i=k+1..N-1} λ_i = exp(sum of log λ over i > k)
    tail = np.concatenate([np.cumsum(logl[::-1])[::-1][1:], [0.0]])
    c = np.exp(tail) * w
    A_rows = [np.sqrt(c[first:])[:, None] * Phi[first:]]
    b_rows = [np.sqrt(c[first:])[:, None] * y2[first:]]
    Ap, bp = _prior_rows(P0, theta0.reshape(n, -1), np.exp(logl.sum()))
    A = np.vstack(A_rows + [Ap])
    b = np.vstack(b_rows + [bp])
    sol = np.linalg.lstsq(A, b, rcond=None)[0]
    return sol[:, 0] if y.ndim == 1 else sol


def kalman_random_walk(Phi, y, Q, r2, theta0, P0):
    """Textbook Kalman filter, measurement update then time update (covariance form)."""
    th = theta0.astype(float).copy()
    P = P0.astype(float).copy()
    out = np.empty((len(y), len(th)))
    err = np.empty(len(y))
    for k in range(len(y)):
        phi = Phi[k]
        e = y[k] - phi @ th
        S = r2 + phi @ P @ phi
        K = P @ phi / S
        th = th + K * e
        P = P - np.outer(K, phi @ P) + Q
        P = 0.5 * (P + P.T)
        out[k] = th
        err[k] = e
    return out, err, P

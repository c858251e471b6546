"""Conversions between a covariance P and its U-D factors (NumPy, no inverse)."""

from __future__ import annotations

import numpy as np

__all__ = ["ud_from_P", "P_from_ud"]


def ud_from_P(P: np.ndarray):
    """Upper U-D factors of an SPD matrix: P = U diag(D) Uᵀ, U unit upper.

    Computed from the Cholesky factor of the reversed matrix, so no inverse.
    """
    n = P.shape[0]
    J = P[::-1, ::-1]
    L = np.linalg.cholesky(J)          # J = L Lᵀ
    Ut = L[::-1, ::-1]                 # P = Ut Utᵀ, Ut upper triangular
    d = np.diag(Ut).copy()
    U = Ut / d                         # unit upper
    U[np.tril_indices(n, -1)] = 0.0
    np.fill_diagonal(U, 1.0)
    return U, d * d


def P_from_ud(U, D):
    """P = U diag(D) Uᵀ, exactly symmetric (also for stacks of factors)."""
    with np.errstate(over="ignore", invalid="ignore"):  # a wound-up P: inf, and a warning of ours
        P = U @ (D[..., :, None] * np.swapaxes(U, -1, -2))
    return 0.5 * P + 0.5 * np.swapaxes(P, -1, -2)  # exactly symmetric, no overflow

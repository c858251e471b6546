r"""The covariance block of the state: P, its U-D factors, the excitation.

The state holds P = U D Uᵀ after θ as U by columns and D (RLS's other forms
override :func:`covariance_of` and :func:`ud_views`: :mod:`._rlsforms`); the
gradient estimators (``spec.covariance`` False) have none and raise
AttributeError. The functions are methods (and properties) of
:class:`~adaptid.estimators._engine.RecursiveEstimator` (bound there by name).
"""

from __future__ import annotations

import numpy as np

from ._factor import P_from_ud

__all__ = ["no_covariance", "ud_views", "P", "covariance_of", "excitation"]


def no_covariance(self, what):
    """The AttributeError of a covariance asked of a gradient estimator (θ only)."""
    return AttributeError(
        f"{type(self).__name__} has no {what}: a gradient estimator keeps only θ, "
        "no covariance P (use RLS or KalmanRLS for one)")


def ud_views(self, S):
    """(U, D): views of the U-D factors of P in state rows S (…, L)."""
    if not self.spec.covariance:
        raise self._no_covariance("covariance factor")
    n, p = self.n_params, self.n_outputs
    U = np.swapaxes(S[..., n * p: n * p + n * n].reshape(S.shape[:-1] + (n, n)), -1, -2)
    D = S[..., n * p + n * n: n * p + n * n + n]
    return U, D


def P(self) -> np.ndarray:
    """Current covariance (n, n), or (B, n, n), formed from its U-D factors.

    AttributeError for the gradient estimators (LMS, NLMS), which have none.
    """
    if not self.spec.covariance:
        raise self._no_covariance("covariance P")
    P = self._covariance_of(self._S)
    if self._diffuse:
        P[~self._identified_of(self._S)] = np.inf
    return P


def covariance_of(self, S):
    """P from state rows S (…, L): from the U-D factors (RLS overrides it per form)."""
    return P_from_ud(*self._ud_views(S))


def excitation(self):
    r"""Smallest eigenvalue of the information matrix :math:`R = P^{-1}`.

    For RLS with forgetting R is the exponentially weighted information
    :math:`\sum_j \lambda^{k-j}w_j\varphi_j\varphi_j^T` plus the decayed
    prior; for the sliding window the information of the samples in the
    window plus the decayed prior. A value near zero (relative to the
    regressors' scale) means some direction is not excited: its
    parameter combination is not identifiable from the recent data.
    Float, or (B,) after ``run_batched``; 0 while a diffuse start
    (``P0="diffuse"``) is not identified. AttributeError for the
    gradient estimators (no P).
    """
    if not self.spec.covariance:
        raise self._no_covariance("excitation (it needs the covariance P)")
    P = self.P
    ident = self._identified_of(self._S)
    ev = np.linalg.eigvalsh(np.where(ident[..., None, None], P, np.eye(self.n_params)))
    ex = np.where(ident, 1.0 / ev[..., -1], 0.0)  # not identified: a direction unexcited
    return ex if self._batch is not None else float(ex)

"""Run the compiled pseudo-linear recursion with the settings of a core estimator."""

from __future__ import annotations

import warnings

import numpy as np

from .._exceptions import DefinitenessLossWarning
from .._validation import param_error
from ._kernels import pseudolinear_run

__all__ = ["estimator_settings", "run_pseudolinear"]


def estimator_settings(estimator, n):
    """(λ, Q, kalman, r2, M, θ, U, D, strategy) from an RLS / SlidingWindowRLS /
    KalmanRLS (or defaults); strategy = (mode, params, P_max), mode −1 for none.

    The estimator is read, never modified: its current θ and U-D factors are
    the starting point (θ₀, P₀ for a fresh one), its options the algorithm.
    """
    from ..estimators import KalmanRLS, RLS, SlidingWindowRLS

    if estimator is None:
        return (1.0, np.zeros((n, n)), False, 1.0, 0, np.zeros(n), np.eye(n), np.full(n, 1e4),
                (-1, np.zeros(1), np.inf))
    if not isinstance(estimator, (RLS, SlidingWindowRLS, KalmanRLS)):
        raise param_error("estimator", "None or an adaptid RLS, SlidingWindowRLS or KalmanRLS",
                          estimator, exc=TypeError)
    if estimator.n_params != n:
        raise param_error("estimator", f"an estimator with n_params={n} (the model's parameters)",
                          f"<n_params={estimator.n_params}>")
    if estimator.batch_size is not None or estimator.n_outputs != 1 or \
            np.ndim(estimator.theta) != 1:
        raise param_error("estimator", "a single-stream, single-output estimator",
                          "<a batched or multi-output estimator>")
    ks = estimator.kernel_settings()
    theta = np.ascontiguousarray(ks.theta[:, 0])
    U, D = np.ascontiguousarray(ks.U), np.ascontiguousarray(ks.D)
    strategy = (ks.strategy_mode, np.asarray(ks.strategy_params, dtype=np.float64), ks.P_max)
    kalman = ks.method == "kalman"
    return (ks.forgetting, np.ascontiguousarray(ks.process_cov), kalman, ks.noise_var,
            ks.window, theta, U, D, strategy)


def run_pseudolinear(Phi_fix, Y, groups, alpha, beta, sgn, estimator):
    """One compiled RELS / PLR pass; returns (Th, E, V, theta, P, Lk).

    Lk holds the λₖ a forgetting strategy applied (None without one).

    ``groups = (col_group, dyn_group, dyn_lag, G)`` describes the dynamic
    columns and the signals they lag (see :func:`pseudolinear_run`).
    """
    from .._config import DOWNDATE_RTOL

    col_group, dyn_group, dyn_lag, G = groups
    nd = dyn_group.shape[0]
    n = Phi_fix.shape[1] + nd
    lam, Q, kalman, r2, M, theta, U, D, (mode, fp, pmax) = estimator_settings(estimator, n)
    N = Y.shape[0]
    Th = np.empty((N, n))
    E = np.empty(N)
    V = np.empty((N, G))
    Lk = np.empty(N)
    refused = pseudolinear_run(np.ascontiguousarray(Phi_fix, dtype=np.float64),
                               np.ascontiguousarray(Y, dtype=np.float64),
                               np.ascontiguousarray(col_group, dtype=np.int64),
                               np.ascontiguousarray(dyn_group, dtype=np.int64),
                               np.ascontiguousarray(dyn_lag, dtype=np.int64),
                               float(alpha), float(beta), float(sgn), theta, U, D,
                               lam, Q, kalman, r2, M, DOWNDATE_RTOL, mode, fp, pmax,
                               Th, E, V, Lk)
    if refused < 0:
        raise FloatingPointError("the Kalman time update P + Q lost positive definiteness "
                                 "(P overflowed?)")
    if refused:
        warnings.warn(f"{refused} window removal(s) refused: they would have made P indefinite "
                      "or nearly so (the window then holds older samples too)",
                      DefinitenessLossWarning, stacklevel=3)
    P = (U * D) @ U.T
    return Th, E, V, theta, 0.5 * (P + P.T), (Lk if mode >= 0 else None)

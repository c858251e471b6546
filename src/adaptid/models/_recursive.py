"""Run the compiled pseudo-linear recursion with the settings of a core estimator."""

from __future__ import annotations

import warnings

import numpy as np

from .._exceptions import DefinitenessLossWarning
from .._validation import param_error
from .._kernels.layers._pseudolinear import pseudolinear_run

__all__ = ["estimator_settings", "regressors_used", "run_pseudolinear", "run_signals",
           "signal_spec"]


def estimator_settings(estimator, n):
    """(λ, Q, kalman, r2, M, θ, U, D, strategy, diffuse) from an RLS /
    SlidingWindowRLS / KalmanRLS (or defaults); strategy = (mode, params,
    P_max), mode −1 for none; diffuse = (state, rank tolerance), the state
    empty for a finite prior.

    The estimator is read, never modified: its current θ and U-D factors are
    the starting point (θ₀, P₀ for a fresh one), its options the algorithm.
    With ``P0="diffuse"`` the diffuse part of its state is the starting
    point too (RLS, Kalman); a diffuse window must be fresh (its buffer is
    not carried over).
    """
    from ..estimators import KalmanRLS, RLS, SlidingWindowRLS

    if estimator is None:
        return (1.0, np.zeros((n, n)), False, 1.0, 0, np.zeros(n), np.eye(n), np.full(n, 1e4),
                (-1, np.zeros(1), np.inf), (np.zeros(0), 0.0))
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
            ks.window, theta, U, D, strategy, _diffuse_settings(estimator, ks))


def _diffuse_settings(estimator, ks):
    """(diffuse state for the kernel, rank tolerance); an empty state for a finite prior."""
    from .. import _config

    if ks.diffuse_state is None:
        return np.zeros(0), 0.0
    if ks.method == "kalman":
        return np.array(ks.diffuse_state), _config.DIFFUSE_KALMAN_TOL
    if ks.method == "window":
        if estimator.n_updates or estimator.n_skipped:
            raise param_error("estimator", "a fresh SlidingWindowRLS (reset()) with "
                              "P0='diffuse' (the recursion keeps its own window buffer)",
                              f"<a diffuse window after {estimator.n_updates} updates>")
        return np.zeros(1), _config.DIFFUSE_RCOND
    return np.array(ks.diffuse_state), _config.DIFFUSE_RCOND


def signal_spec(groups, alpha, beta, sgn, n):
    """The general signal description (α (G,), mix (G, n), dyn_group, dyn_lag,
    dyn_sgn) of ARMAX / OE's (col_group, dyn_group, dyn_lag, G), α, β, sgn:
    signal g is α y + β Σ_{col_group[i] = g} φᵢθᵢ, every dynamic column
    enters with the sign ``sgn``."""
    col_group, dyn_group, dyn_lag, G = groups
    col_group = np.asarray(col_group, dtype=np.int64)
    mix = np.zeros((G, n))
    mix[col_group, np.arange(n)] = beta
    nd = np.asarray(dyn_group).shape[0]
    return (np.full(G, float(alpha)), mix, dyn_group, dyn_lag, np.full(nd, float(sgn)))


def run_pseudolinear(Phi_fix, Y, groups, alpha, beta, sgn, estimator):
    """ARMAX / OE's recursion; see :func:`run_signals` (this converts with
    :func:`signal_spec`). Returns (Th, E, V, theta, P, Lk)."""
    n = Phi_fix.shape[1] + np.asarray(groups[1]).shape[0]
    return run_signals(Phi_fix, Y, signal_spec(groups, alpha, beta, sgn, n), estimator)[:6]


def run_signals(Phi_fix, Y, spec, estimator, identified=None, row_bounds=None):
    """One compiled RELS / PLR pass; returns (Th, E, V, theta, P, Lk, n_rebuilds).

    Lk holds the λₖ a forgetting strategy applied (None without one).
    ``spec = (alpha, mix, dyn_group, dyn_lag, dyn_sgn)`` describes the
    signals the recursion forms and the dynamic columns that lag them (see
    :func:`pseudolinear_run`). A sliding window whose removal would lose
    definiteness is re-solved from its buffer (``n_rebuilds`` counts them,
    with one :class:`DefinitenessLossWarning`), as
    :class:`~adaptid.SlidingWindowRLS` does. With an estimator with
    ``P0="diffuse"`` the start is exact (see :mod:`adaptid._kernels.layers._pseudolinear`);
    ``identified``, an optional (N,) float array, then receives per sample
    1.0 once the data determine θ (0.0 before; P is inf while not identified).
    ``row_bounds`` (P + 1,), the first row of each of P pieces (experiments,
    runs between gaps) and N: the signals' lags restart from zero at each
    piece, the estimator's state runs on (default: one piece).
    """
    from .._config import DOWNDATE_RTOL

    alpha, mix, dyn_group, dyn_lag, dyn_sgn = spec
    nd = np.asarray(dyn_group).shape[0]
    n = Phi_fix.shape[1] + nd
    lam, Q, kalman, r2, M, theta, U, D, (mode, fp, pmax), (dif, dtol) = \
        estimator_settings(estimator, n)
    N = Y.shape[0]
    Ik = np.empty(N) if identified is None else identified
    G = np.asarray(alpha).shape[0]
    Th = np.empty((N, n))
    E = np.empty(N)
    V = np.empty((N, G))
    Lk = np.empty(N)
    rb = np.array([0, N] if row_bounds is None else row_bounds, dtype=np.int64)
    status = pseudolinear_run(np.ascontiguousarray(Phi_fix, dtype=np.float64),
                              np.ascontiguousarray(Y, dtype=np.float64),
                              np.ascontiguousarray(alpha, dtype=np.float64),
                              np.ascontiguousarray(mix, dtype=np.float64),
                              np.ascontiguousarray(dyn_group, dtype=np.int64),
                              np.ascontiguousarray(dyn_lag, dtype=np.int64),
                              np.ascontiguousarray(dyn_sgn, dtype=np.float64),
                              theta, U, D, lam, Q, kalman, r2, M, DOWNDATE_RTOL, mode, fp, pmax,
                              Th, E, V, Lk, dif, dtol, Ik, rb)
    if status < 0:
        raise FloatingPointError("the Kalman time update P + Q lost positive definiteness "
                                 "(P overflowed?)")
    if status:
        warnings.warn(f"pseudo-linear recursion: {status} removal(s) from the window would have "
                      "lost positive definiteness; the window was re-solved exactly from its "
                      "buffer of the regressors used (poorly excited window?)",
                      DefinitenessLossWarning, stacklevel=3)
    P = (U * D) @ U.T
    if dif.shape[0] and dif[0] == 0.0:
        P = np.full((n, n), np.inf)
    return (Th, E, V, theta, 0.5 * (P + P.T), (Lk if mode >= 0 else None), int(status))


def regressors_used(Phi_fix, V, spec, row_bounds=None):
    """The regressor rows the recursion formed: ``Phi_fix`` followed by the dynamic
    columns ``dyn_sgn[j] * V[k - dyn_lag[j], dyn_group[j]]`` (0 before the first row
    of each piece of ``row_bounds``, default one piece)."""
    alpha, mix, dyn_group, dyn_lag, dyn_sgn = spec
    N = V.shape[0]
    bounds = [0, N] if row_bounds is None else [int(b) for b in row_bounds]
    dyn = np.zeros((N, np.asarray(dyn_group).shape[0]))
    for j, (g, lag, sg) in enumerate(zip(dyn_group, dyn_lag, dyn_sgn)):
        for s, e in zip(bounds[:-1], bounds[1:]):
            if lag < e - s:
                dyn[s + lag:e, j] = sg * V[s:e - lag, g]
    return np.hstack([Phi_fix, dyn])

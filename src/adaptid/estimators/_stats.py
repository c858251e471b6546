r"""The one rule for σ̂² and the standard errors of a recursive fit.

Used by ``adaptid fit``, ``adaptid fleet``, the models' recursive fits and
:class:`adaptid.sklearn.RLSRegressor`, so that the same data give the same
numbers everywhere.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._validation import as_float_array, param_error
from ._sigma2 import sigma2_rule

__all__ = ["RecursiveFitStats", "recursive_fit_stats", "sample_factors", "sigma2_rule"]


@dataclass(frozen=True)
class RecursiveFitStats:
    """σ̂², standard errors and their degrees of freedom (see :func:`recursive_fit_stats`).

    ``scale`` = σ̂²/R₂ turns the estimator's P into the covariance of θ̂,
    ``cov = scale · P`` (R₂ the Kalman filter's ``noise_var``, 1 otherwise).
    """

    sigma2: float
    stderr: np.ndarray
    dof: float
    n_eff: float
    ssr: float
    scale: float = float("nan")


def sample_factors(kind, N, *, forgetting=None, window=None, used=None):
    r"""The factor :math:`c_k` with which sample k enters the cost at the end of a run.

    ``"rls"``: :math:`c_k = \prod_{i=k+1}^{N}\lambda_i` (1 without forgetting);
    ``"window"``: the same inside the last ``window`` used samples, 0 before;
    ``"kalman"``, ``"lms"``, ``"nlms"``: 1. Skipped samples (``used`` False) get 0 and take no time.
    """
    used = np.ones(N, dtype=bool) if used is None else np.asarray(used, dtype=bool)
    lam = np.ones(N) if forgetting is None else np.broadcast_to(
        np.asarray(forgetting, dtype=np.float64), (N,))
    loglam = np.where(used, np.log(np.where(used, lam, 1.0)), 0.0)
    # c_k = exp(Σ_{i>k} log λ_i): reverse cumulative sum, shifted by one
    tail = np.concatenate([np.cumsum(loglam[::-1])[::-1][1:], [0.0]]) if N else np.empty(0)
    c = np.where(used, np.exp(tail), 0.0) if kind != "kalman" else used.astype(float)
    if kind == "window":
        keep = np.cumsum(used[::-1])[::-1] <= window
        c = np.where(keep, c, 0.0)
    return c


def recursive_fit_stats(est, Phi, y, *, weights=None, forgetting=None, used=None):
    r"""σ̂² and standard errors of a recursive estimator after a run over (Φ, y).

    With :math:`\hat\theta_N` the final estimate, :math:`r_k = y_k -
    \varphi_k^T\hat\theta_N` its residuals, :math:`w_k` the sample weights and
    :math:`c_k` the factor with which sample k enters the estimator's cost
    (:func:`sample_factors`: :math:`\prod_{i>k}\lambda_i` under forgetting, 1
    inside the sliding window and 0 before it, 1 for the Kalman filter),

    .. math::

        \hat\sigma^2 = \frac{\sum_k c_k w_k r_k^2}{\sum_k c_k - n},\qquad
        \mathrm{se}_i = \sqrt{\hat\sigma^2\,P_{ii}/R_2},

    :math:`R_2` the Kalman filter's ``noise_var`` (1 otherwise). Without
    forgetting and with a diffuse prior this is exactly ordinary (weighted)
    least squares: σ̂² = SSR/(N − n) and se = :func:`adaptid.lstsq`'s
    ``stderr``; for the window, the same over the samples in the window.

    The gradient estimators (:class:`~adaptid.LMS`, :class:`~adaptid.NLMS`)
    minimise no cost and keep no covariance: σ̂² is the same sum with
    :math:`c_k = 1` (the final estimate's residual variance over the used
    samples) and ``stderr`` is NaN.

    Parameters
    ----------
    est : RLS, SlidingWindowRLS, KalmanRLS, LMS or NLMS
        The estimator after its run (single stream, single output).
    Phi : array_like, shape (N, n)
    y : array_like, shape (N,)
        The samples of the run (of every run since the prior, if the
        estimator was resumed from a state file).
    weights : array_like, shape (N,), optional
    forgetting : array_like, shape (N,), optional
        λₖ applied (``Trajectory.forgetting`` for strategies); default the
        estimator's constant λ.
    used : array_like of bool, shape (N,), optional
        False for the samples that were skipped (``Trajectory.skipped``
        negated); default: the samples with finite φ and y.

    Returns
    -------
    RecursiveFitStats
        ``sigma2`` (NaN when the degrees of freedom are not positive),
        ``stderr`` (n,), ``dof`` = Σcₖ − n, ``n_eff`` = Σcₖ, ``ssr`` = Σcₖwₖrₖ²,
        ``scale`` = σ̂²/R₂ (``cov = scale · P``).
    """
    from ._factory import method_of
    kind = method_of(est)
    Phi = as_float_array(Phi, "Phi", ndim=2, finite=False)
    y = as_float_array(y, "y", ndim=1, finite=False)
    N, n = Phi.shape
    if n != est.n_params or y.shape[0] != N:
        raise param_error("Phi, y", f"of shapes (N, {est.n_params}), (N,)",
                          f"<shapes {Phi.shape}, {y.shape}>")
    finite = np.isfinite(Phi).all(axis=1) & np.isfinite(y)
    used = finite if used is None else (np.asarray(used, dtype=bool) & finite)
    w = np.ones(N) if weights is None else np.broadcast_to(np.asarray(weights, float), (N,))
    if forgetting is None and kind != "kalman":
        lam = getattr(est, "_lam", None)
        forgetting = 1.0 if lam is None else lam
    c = sample_factors(kind, N, forgetting=forgetting, window=getattr(est, "window", None),
                       used=used)
    theta = np.asarray(est.theta, dtype=np.float64).reshape(n)
    with np.errstate(invalid="ignore", over="ignore"):
        r = np.where(used, y - np.where(used[:, None], Phi, 0.0) @ theta, 0.0)
        ssr = float(np.sum(c * w * r * r))
    n_eff = float(np.sum(c))
    dof = n_eff - n
    if not type(est).spec.covariance:  # LMS / NLMS: no P, no standard errors
        sigma2 = ssr / dof if dof > 0 else float("nan")
        return RecursiveFitStats(sigma2=sigma2, stderr=np.full(n, np.nan), dof=dof,
                                 n_eff=n_eff, ssr=ssr,
                                 scale=sigma2 if np.isfinite(sigma2) else float("nan"))
    r2 = float(getattr(est, "noise_var", 1.0))
    sigma2, stderr = sigma2_rule(np.array([ssr]), np.float64(n_eff), n,
                                 np.diagonal(np.asarray(est.P)), r2)
    s2 = float(sigma2[0])
    return RecursiveFitStats(sigma2=s2, stderr=stderr[:, 0], dof=dof, n_eff=n_eff, ssr=ssr,
                             scale=s2 / r2 if np.isfinite(s2) else float("nan"))

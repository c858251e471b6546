r"""Least squares of the MIMO ARX equations, batch and recursive, and their covariance.

Equation i is the regression :math:`y^{(i)} = \Phi_i\theta_i + e^{(i)}`
over the common rows. Each :math:`\theta_i` is ordinary least squares (QR,
:func:`adaptid.lstsq`); when every equation has the same regressors
(:math:`\Phi_i = \Phi`) one QR of Φ solves all outputs at once (the
multi-column right-hand side), otherwise one QR per equation.

With :math:`E` the residuals (one column per output) and
:math:`d_i` the number of parameters of equation i, the innovation
covariance is

.. math::

    \hat\Sigma_{ij} = \frac{e^{(i)T}e^{(j)}}{\sqrt{(n - d_i)(n - d_j)}}

(statsmodels' ``VAR.sigma_u`` when the regressors are shared), and the
covariance of the stacked estimate :math:`\theta = [\theta_1; \dots;
\theta_{n_y}]` has the blocks

.. math::

    \operatorname{cov}(\hat\theta_i, \hat\theta_j)
      = \hat\Sigma_{ij}\,\Phi_i^+\Phi_i^{+T}\ \text{(i = j: } \hat\sigma_i^2(\Phi_i^T\Phi_i)^{-1}),
    \qquad \Phi_i^+ = (\Phi_i^T\Phi_i)^{-1}\Phi_i^T = R_i^{-1}R_i^{-T}\Phi_i^T,

from the triangular factors of the QR (never an inverse of
:math:`\Phi^T\Phi`): the sandwich form of :math:`\hat\theta_i - \theta_i =
\Phi_i^+e^{(i)}` with :math:`E[e^{(i)}e^{(j)T}] = \Sigma_{ij}I`
(Lütkepohl 2005, sec. 3.2; for shared regressors :math:`\hat\Sigma\otimes
(\Phi^T\Phi)^{-1}`, statsmodels' ``VARResults.cov_params``). Its diagonal
blocks are the per-equation least-squares covariances.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import linalg

from ..._validation import param_error

__all__ = ["LSFit", "batch_fit", "recursive_fit", "noise_covariance"]


@dataclass(frozen=True)
class LSFit:
    """θ per equation, residuals (n, ny), innovation covariance, full covariance (d, d)."""

    thetas: tuple
    residuals: np.ndarray
    noise_cov: np.ndarray
    cov: np.ndarray


def noise_covariance(E, dofs, weights=None):
    r""":math:`\hat\Sigma_{ij} = \sum_k c_k e_{ki}e_{kj}/\sqrt{\mathrm{dof}_i\,\mathrm{dof}_j}`."""
    Ew = E if weights is None else E * weights[:, None]
    dofs = np.asarray(dofs, dtype=np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        S = (Ew.T @ E) / np.sqrt(np.outer(dofs, dofs))
    S[~np.isfinite(S)] = np.nan
    return S


def _blocks(Sigma, grams):
    """The stacked covariance from Σ and the d_i × d_j matrices grams(i, j)."""
    ny = Sigma.shape[0]
    rows = [np.hstack([Sigma[i, j] * grams(i, j) for j in range(ny)]) for i in range(ny)]
    return np.vstack(rows)


def batch_fit(Phis, T, shared):
    """Least squares of every equation (one QR when ``shared``) and the covariances."""
    from ..._lstsq import lstsq

    n, ny = T.shape
    ds = [P.shape[1] for P in Phis]
    for i, d in enumerate(ds):
        if n <= d:
            raise param_error("data", f"more rows than the {d} parameters of equation {i} "
                              "(a longer record)", f"<{n} rows>")
    if shared:
        res = lstsq(Phis[0], T)
        Theta = np.asarray(res.theta).reshape(ds[0], ny)
        E = np.asarray(res.residuals).reshape(n, ny)
        thetas = tuple(Theta[:, i].copy() for i in range(ny))
        G = res.unscaled_cov
        grams = lambda i, j: G  # noqa: E731
    else:
        pinv, thetas, cols = [], [], []
        for i, Phi in enumerate(Phis):
            res = lstsq(Phi, T[:, i])
            thetas.append(np.asarray(res.theta))
            cols.append(np.asarray(res.residuals))
            R = res._R
            # Φ⁺ = R⁻¹R⁻ᵀΦᵀ by two triangular solves
            pinv.append(linalg.solve_triangular(R, linalg.solve_triangular(R, Phi.T, trans="T")))
        thetas, E = tuple(thetas), np.column_stack(cols)
        grams = lambda i, j: pinv[i] @ pinv[j].T  # noqa: E731
    Sigma = noise_covariance(E, [n - d for d in ds])
    return LSFit(thetas, E, Sigma, _blocks(Sigma, grams))


def _estimator_for(estimator, d, n_outputs, options):
    """A fresh estimator (method name or None → the factory) or a copy of the given one."""
    from ...estimators import estimator as factory
    from ...estimators._engine import RecursiveEstimator

    if estimator is None or isinstance(estimator, str):
        kw = dict(options)
        if n_outputs is not None:
            kw["n_outputs"] = n_outputs
        return factory(estimator or "rls", d, **kw)
    if options:
        raise param_error("options", "none when an estimator object is given",
                          f"<{sorted(options)}>", exc=TypeError)
    if not isinstance(estimator, RecursiveEstimator):
        raise param_error("estimator", "None, a method name ('rls', 'window', 'kalman') or an "
                          "adaptid recursive estimator", estimator, exc=TypeError)
    p = None if estimator._single else estimator.n_outputs
    if estimator.n_params != d or p != n_outputs:
        raise param_error("estimator", f"an estimator with n_params={d} and n_outputs="
                          f"{n_outputs} (the shared regressors of every equation); or a "
                          "method name", f"<n_params={estimator.n_params}, n_outputs={p}>")
    return estimator.copy()


def _factors(est, traj, n):
    from ...estimators._factory import method_of
    from ...estimators._stats import sample_factors

    used = None if traj.skipped is None else ~np.asarray(traj.skipped).reshape(n, -1).any(axis=1)
    lam = traj.forgetting
    if lam is None and method_of(est) != "kalman":
        lam = getattr(est, "_lam", None)
    return sample_factors(method_of(est), n, forgetting=lam, window=getattr(est, "window", None),
                          used=used)


def recursive_fit(Phis, T, shared, estimator=None, options=None):
    r"""Every equation through a recursive estimator, in one compiled run per estimator.

    Shared regressors: one multi-output estimator (``n_outputs = ny``), one
    P for all outputs; otherwise one single-output estimator per equation.
    σ̂ follows :func:`adaptid.recursive_fit_stats`' rule with the sample
    factors :math:`c_k` (forgetting, window):
    :math:`\hat\Sigma_{ij} = \sum_k c_k e_{ki}e_{kj}/\sqrt{(\sum c - d_i)(\sum c - d_j)}`,
    the covariance blocks :math:`\hat\Sigma_{ij}P_i\Phi_i^TC\Phi_jP_j/R_2`
    (:math:`\hat\Sigma_{ii}P_i/R_2` on the diagonal; :math:`\hat\Sigma\otimes P/R_2`
    when P is shared).

    Returns
    -------
    (LSFit, list of Trajectory, list of estimators)
    """
    options = options or {}
    n, ny = T.shape
    if shared:
        est = _estimator_for(estimator, Phis[0].shape[1], ny, options)
        traj = est.run(Phis[0], T)
        ests, trajs = [est], [traj]
        Theta = np.asarray(est.theta).reshape(-1, ny)
        thetas = tuple(Theta[:, i].copy() for i in range(ny))
    else:
        if estimator is not None and not isinstance(estimator, str):
            raise param_error("estimator", "None or a method name when the equations have "
                              "different regressors (one estimator per equation)",
                              estimator, exc=TypeError)
        ests = [_estimator_for(estimator, P.shape[1], None, options) for P in Phis]
        trajs = [e.run(P, T[:, i]) for i, (e, P) in enumerate(zip(ests, Phis))]
        thetas = tuple(np.asarray(e.theta).reshape(-1).copy() for e in ests)
    E = np.column_stack([T[:, i] - Phis[0 if shared else i] @ thetas[i] for i in range(ny)])
    c = _factors(ests[0], trajs[0], n)
    ds = [th.size for th in thetas]
    Sigma = noise_covariance(E, [c.sum() - d for d in ds], weights=c)
    r2 = float(getattr(ests[0], "noise_var", 1.0))
    if shared:
        P = np.asarray(ests[0].P)
        grams = lambda i, j: P / r2  # noqa: E731
    else:
        Ps = [np.asarray(e.P) for e in ests]
        grams = lambda i, j: (Ps[i] / r2 if i == j else  # noqa: E731
                              Ps[i] @ (Phis[i].T * c) @ Phis[j] @ Ps[j] / r2)
    return LSFit(thetas, E, Sigma, _blocks(Sigma, grams)), trajs, ests

r"""``KalmanRLS.fit_variances``: maximum-likelihood R₁ and R₂ of the random walk.

The objective is the log-likelihood of :mod:`._kalmansmooth` (one compiled
forward pass per evaluation), maximised over log variances with
:func:`scipy.optimize.minimize`; standard errors come from the observed
information (a central-difference Hessian in the log variances, carried to
the variances by the delta method). The function taking ``self`` is a method
of :class:`~adaptid.KalmanRLS` (bound there by name).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np

from .._exceptions import AdaptidWarning
from .._validation import check_choice
from ._kalmansmooth import llf_of, loglike_terms, prepared, prior

__all__ = ["VarianceFit", "fit_variances"]

#: log-variance bounds around the start (a random walk of variance e^-30·R₂ is constant)
_SPAN = 30.0


#: information in a log variance below which it counts as undetermined (se(log v) > 10)
_FLAT = 1e-2


def _Q(q, n):
    return np.eye(n) * q if np.ndim(q) == 0 or len(q) == 1 else np.diag(q)


def _full_llf(data, start, x, k):
    """Log-likelihood at x = [log q (k entries), log R₂]."""
    v = np.exp(x)
    n = data[0].shape[1]
    return llf_of(loglike_terms(*data, start, _Q(v[:k], n), v[k]))


def _profile(data, start, xq, k):
    """Diffuse start: (log-likelihood with R₂ concentrated out, R̂₂) at x = log(q/R₂).

    With R₁ = R₂·q̃ every F of the non-rank steps scales with R₂ and the rank
    steps do not depend on it, so R̂₂ = Σv²/F̃ / m (m ordinary samples)."""
    n = data[0].shape[1]
    acc = loglike_terms(*data, start, _Q(np.exp(xq), n), 1.0)
    if acc[2] == 0:
        return -np.inf, np.nan
    s2 = acc[0] / acc[2]
    acc[1] += acc[2] * math.log(s2)
    acc[0] = acc[2]
    return llf_of(acc), s2


def _hessian(f, x, h=1e-4):
    """Central-difference Hessian of f at x (steps h in the log variances)."""
    k = len(x)
    H = np.empty((k, k))
    f0 = f(x)
    E = np.eye(k) * h
    for i in range(k):
        H[i, i] = (f(x + E[i]) - 2 * f0 + f(x - E[i])) / h ** 2
        for j in range(i):
            H[i, j] = H[j, i] = (f(x + E[i] + E[j]) - f(x + E[i] - E[j]) - f(x - E[i] + E[j])
                                 + f(x - E[i] - E[j])) / (4 * h ** 2)
    return H


def _polish(f, x, steps=4):
    """Newton steps on log L (differenced gradient and Hessian) from the optimiser's x,
    each kept only if it raises log L; returns (x, Hessian at x)."""
    H = _hessian(f, x)
    h = 1e-5
    for _ in range(steps):
        E = np.eye(len(x)) * h
        g = np.array([(f(x + e) - f(x - e)) / (2 * h) for e in E])
        try:
            np.linalg.cholesky(-H)
            dx = np.linalg.solve(H, g)
        except np.linalg.LinAlgError:
            break
        if not np.all(np.isfinite(dx)) or f(x - dx) < f(x):
            break
        x = x - dx
        H = _hessian(f, x)
        if np.max(np.abs(dx)) < 1e-10:
            break
    return x, H


def _start(self, k, per_parameter):
    """Start [log q…, log R₂] from the estimator's own R₁ (its diagonal) and R₂."""
    r2 = float(self.noise_var)
    d = np.diag(self.process_cov).copy()
    d = np.where(d > 0, d, 1e-4 * r2)
    q = d if per_parameter else np.array([d.mean()])
    return np.log(np.append(q, r2))


def fit_variances(self, Phi, y, per_parameter=False, *, weights=None, method="L-BFGS-B",
                  maxiter=1000):
    r"""Maximum-likelihood random-walk variance R₁ and noise variance R₂.

    Maximises the log-likelihood of :meth:`loglike` (the prediction-error
    decomposition, from this estimator's prior θ₀, P₀ or its diffuse start)
    over :math:`R_1 = qI` (or :math:`R_1 = \operatorname{diag}(q_1..q_n)`
    with ``per_parameter=True``) and :math:`R_2`, in the log variances, with
    :func:`scipy.optimize.minimize`, starting from the estimator's own
    ``process_cov`` (its mean diagonal, or the diagonal) and ``noise_var``.
    With ``P0="diffuse"`` the noise variance is concentrated out (Harvey
    1989, §3.4.2; Durbin & Koopman 2012, §7.3.3): with
    :math:`R_1 = R_2\tilde q`, every :math:`F_k` of the non-diffuse steps
    is :math:`R_2\tilde F_k` and

    .. math::

        \hat R_2 = \frac1m\sum_k \frac{v_k^2}{\tilde F_k},

    over the m samples that do not lower the rank of :math:`P_\infty`, so
    only :math:`\log\tilde q` is searched. With a known prior P₀ (which does
    not scale with R₂) both are searched.

    The optimiser's estimate is refined by Newton steps on differenced
    derivatives (kept only when they raise the likelihood). Standard errors:
    the observed information :math:`-\nabla^2\log L` by
    central differences in :math:`x = \log(q, R_2)` at the estimate, its
    inverse :math:`C_x`, and the delta method
    :math:`C = D C_x D`, :math:`D = \operatorname{diag}(q, R_2)`
    (statsmodels' ``cov_type="approx"`` in the variances, to the accuracy
    of the differences). A variance whose logarithm the data leave
    undetermined (information in log v below 0.01, a standard error of
    log v above 10: typically a variance driven to zero, where the usual
    asymptotics do not hold) gets a NaN standard error and an
    :class:`~adaptid.AdaptidWarning`.

    Parameters
    ----------
    Phi : array_like, shape (N, n)
    y : array_like, shape (N,)
    per_parameter : bool
        One random-walk variance per parameter instead of one for all.
    weights : float or array_like, shape (N,), optional
        As for :meth:`loglike`.
    method : str
        A bounded method of :func:`scipy.optimize.minimize`
        ("L-BFGS-B", "Powell", "Nelder-Mead", "TNC").
    maxiter : int

    Returns
    -------
    VarianceFit
        ``process_var`` (float, or (n,) with ``per_parameter``),
        ``noise_var``, ``stderr``, ``cov``, ``loglike``, ``converged``;
        ``summary()``, ``to_frame()`` and ``estimator()``, a
        :class:`KalmanRLS` with these variances and this estimator's prior.
    """
    from scipy.optimize import minimize

    method = check_choice(method, "method", ("L-BFGS-B", "Powell", "Nelder-Mead", "TNC"))
    per_parameter = bool(per_parameter)
    _, Phi, y, w = prepared(self, Phi, y, weights, "fit_variances")
    data, start, n = (Phi, y, w), prior(self), Phi.shape[1]
    k = n if per_parameter else 1
    x0 = _start(self, k, per_parameter)
    if self._diffuse:
        x0 = x0[:k] - x0[k]
        res = minimize(lambda x: -_profile(data, start, x, k)[0] / len(y), x0, method=method,
                       bounds=[(x - _SPAN, x + _SPAN) for x in x0],
                       options={"maxiter": maxiter})
        s2 = _profile(data, start, res.x, k)[1]
        x = np.append(res.x + math.log(s2), math.log(s2))
    else:
        res = minimize(lambda x: -_full_llf(data, start, x, k) / len(y), x0, method=method,
                       bounds=[(x - _SPAN, x + _SPAN) for x in x0],
                       options={"maxiter": maxiter})
        x = res.x
    f = lambda z: _full_llf(data, start, z, k)  # noqa: E731 - the Hessian's objective
    x, H = _polish(f, x)
    cov = _delta_cov(H, np.exp(x))
    return VarianceFit(process_var=np.exp(x[:k]) if per_parameter else float(np.exp(x[0])),
                       noise_var=float(np.exp(x[k])), cov=cov, loglike=f(x),
                       n_obs=int(np.count_nonzero(np.isfinite(y) & (w > 0))),
                       converged=bool(res.success), n_iter=int(res.get("nit", 0)),
                       message=str(res.message), _prior=self)


def _delta_cov(H, v):
    """Covariance of the variances v from the Hessian H of log L in log v.

    A variance whose log the data do not determine (its information in log v
    below :data:`_FLAT`, i.e. a standard error of log v above 10: typically a
    variance driven to zero, on the boundary where the usual asymptotics do
    not hold) gets no standard error (NaN); the others come from the
    information of the rest."""
    info = -H
    keep = np.diag(info) > _FLAT
    C = np.full(H.shape, np.nan)
    try:
        L = np.linalg.cholesky(info[np.ix_(keep, keep)])
    except np.linalg.LinAlgError:
        keep[:] = False
    if not keep.all():
        warnings.warn("the data do not determine the log of the variances at positions "
                      f"{np.flatnonzero(~keep).tolist()} of params (at their lower bound?): "
                      "their standard errors are NaN",
                      AdaptidWarning, stacklevel=3)
    if keep.any():
        Li = np.linalg.solve(L, np.eye(L.shape[0]))  # triangular, k × k
        C[np.ix_(keep, keep)] = (Li.T @ Li) * np.outer(v[keep], v[keep])
    return C


@dataclass(frozen=True, eq=False)
class VarianceFit:
    r"""Maximum-likelihood variances of :meth:`KalmanRLS.fit_variances`.

    Attributes
    ----------
    process_var : float or ndarray, shape (n,)
        :math:`\hat q` (:math:`R_1 = \hat qI`) or the diagonal of :math:`R_1`.
    noise_var : float
        :math:`\hat R_2`.
    cov : ndarray, shape (k + 1, k + 1)
        Covariance of (q…, R₂) from the observed information (delta method).
    loglike : float
        The log-likelihood at the estimate.
    n_obs : int
        Samples that entered the likelihood.
    converged : bool
    n_iter : int
    message : str
        The optimiser's.
    """

    process_var: object
    noise_var: float
    cov: np.ndarray
    loglike: float
    n_obs: int
    converged: bool
    n_iter: int
    message: str
    _prior: object = field(repr=False, default=None)

    @property
    def params(self) -> np.ndarray:
        """(q…, R₂) as one vector."""
        return np.append(np.ravel(self.process_var), self.noise_var)

    @property
    def stderr(self) -> np.ndarray:
        """Standard errors of :attr:`params`."""
        return np.sqrt(np.diag(self.cov))

    @property
    def param_names(self) -> tuple:
        q = np.ravel(self.process_var)
        names = ("process_var",) if q.size == 1 and np.ndim(self.process_var) == 0 else \
            tuple(f"process_var[{i}]" for i in range(q.size))
        return names + ("noise_var",)

    def estimator(self):
        """A :class:`~adaptid.KalmanRLS` with these variances and the prior (θ₀, P₀
        or diffuse), NaN policy and outputs of the estimator that was fitted."""
        src = self._prior
        q = self.process_var
        R1 = np.diag(q) if np.ndim(q) else q
        theta0 = None if src.diffuse else src.theta0[:, 0]
        return type(src)(src.n_params, process_cov=R1, noise_var=self.noise_var, theta0=theta0,
                         P0=src.P0, nan_policy=src.nan_policy)

    def summary(self, *, alpha=0.05):
        """:class:`~adaptid.Summary` of the variances (normal limits, from the
        observed information), the log-likelihood, AIC and BIC."""
        from .._summary import Summary, parameter_rows
        k = self.params.size
        stats = {"N": self.n_obs, "log-likelihood": float(self.loglike),
                 "AIC": -2 * self.loglike + 2 * k,
                 "BIC": -2 * self.loglike + k * math.log(max(self.n_obs, 1)),
                 "converged": self.converged, "iterations": self.n_iter}
        return Summary(title="KalmanRLS variances (maximum likelihood)", names=self.param_names,
                       params=parameter_rows(self.params, self.stderr, np.inf, alpha), stats=stats,
                       alpha=alpha, notes=("Standard errors: observed information in the log "
                                           "variances, delta method.",))

    def to_frame(self):
        """The parameter table of :meth:`summary` as a DataFrame (requires pandas)."""
        return self.summary().to_frame()

r"""Statistical primitives shared by every layer (numpy and scipy only).

The models (layer 5) need the residual tests and information criteria that
:mod:`adaptid.diagnostics` (layer 6) also offers; both use these functions,
so there is one formula for each number:

* :func:`gaussian_llf` — Gaussian log-likelihood at the ML noise variance;
* :func:`information_criteria` — AIC, BIC (statsmodels' definitions) and
  Akaike's FPE;
* :func:`ljung_box` — residual autocorrelation, its band and the Ljung–Box
  portmanteau test;
* :func:`cross_correlation` — residual–input cross-correlation, its band and
  the Box–Jenkins portmanteau test;
* :func:`fit_percent` — MATLAB's normalised (NRMSE) fit in percent;
* :func:`t_table` — t statistics, two-sided p-values and confidence limits.
"""

from __future__ import annotations

import numpy as np

from ._lazy import lazy

stats = lazy("scipy.stats")

__all__ = [
    "gaussian_llf",
    "information_criteria",
    "ljung_box",
    "cross_correlation",
    "fit_percent",
    "t_table",
]


def gaussian_llf(ssr, nobs, *, log_weights=0.0):
    r"""Gaussian log-likelihood at the ML variance :math:`\hat\sigma^2_{ML} = \mathrm{SSR}/N`.

    .. math::

        \ell = -\frac N2\left(\log 2\pi + \log\frac{\mathrm{SSR}}{N} + 1\right)
               + \frac12\sum_k\log w_k ,

    the concentrated likelihood of statsmodels' ``OLS``/``WLS.loglike``
    (``log_weights`` = Σ log wₖ for weighted least squares).
    """
    ssr = np.asarray(ssr, dtype=np.float64)
    nobs = np.asarray(nobs, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        out = -0.5 * nobs * (np.log(2.0 * np.pi) + np.log(ssr / nobs) + 1.0) + 0.5 * log_weights
    return float(out) if out.ndim == 0 else out


def information_criteria(llf, nobs, n_params, *, loss=None):
    r"""AIC, BIC and FPE of a fit with ``n_params`` estimated parameters.

    .. math::

        \mathrm{AIC} = -2\ell + 2d,\qquad \mathrm{BIC} = -2\ell + d\log N,\qquad
        \mathrm{FPE} = V\,\frac{1 + d/N}{1 - d/N},

    (statsmodels' ``aic``/``bic``, which count the regression coefficients
    only; Ljung 1999, eq. 16.31 for FPE with V the loss Σε²/N).

    Returns
    -------
    dict
        ``aic``, ``bic`` and, when ``loss`` is given, ``fpe`` (inf for N ≤ d).
    """
    llf = np.asarray(llf, dtype=np.float64)
    out = {"aic": -2.0 * llf + 2.0 * n_params, "bic": -2.0 * llf + np.log(nobs) * n_params}
    if loss is not None:
        out["fpe"] = (np.asarray(loss, dtype=np.float64) * (1 + n_params / nobs) / (1 - n_params / nobs)
                      if nobs > n_params else np.full(np.shape(loss), np.inf))
    return {k: (float(v) if np.ndim(v) == 0 else v) for k, v in out.items()}


def _centre(x):
    xc = np.asarray(x, dtype=np.float64) - np.mean(x)
    return xc, float(xc @ xc)


def ljung_box(e, max_lag, alpha, ddof=0):
    r"""Autocorrelation of ``e`` at lags 0 … M, its band and the Ljung–Box test.

    .. math::

        r(\tau) = \frac{\sum_{t>\tau}\tilde e_t\tilde e_{t-\tau}}{\sum_t\tilde e_t^2},\qquad
        Q = N(N+2)\sum_{\tau=1}^{M}\frac{r(\tau)^2}{N-\tau}\sim\chi^2_{M-\mathrm{ddof}},

    band :math:`z_{1-\alpha/2}/\sqrt N` (Ljung & Box 1978; Ljung 1999, sec. 16.6).
    The caller validates ``e`` (finite, 1-D, not constant) and the lags.

    Returns
    -------
    dict
        ``acf`` (M + 1,), ``band``, ``q_stat``, ``dof``, ``p_value``.
    """
    ec, ss = _centre(e)
    N = ec.size
    acf = np.array([(ec[tau:] @ ec[:N - tau]) / ss for tau in range(max_lag + 1)])
    taus = np.arange(1, max_lag + 1)
    q = float(N * (N + 2) * np.sum(acf[1:] ** 2 / (N - taus)))
    dof = max_lag - ddof
    return {"acf": acf, "band": float(stats.norm.ppf(1 - alpha / 2) / np.sqrt(N)), "q_stat": q,
            "dof": dof, "p_value": float(stats.chi2.sf(q, dof))}


def cross_correlation(u, e, max_lag, alpha, ddof=0):
    r"""Cross-correlation of ``e`` with ``u`` τ samples earlier, τ = −M … M, and its test.

    .. math::

        r_{\varepsilon u}(\tau) = \frac{\sum_t\tilde e_t\tilde u_{t-\tau}}
            {\sqrt{\sum\tilde e_t^2\sum\tilde u_t^2}},\qquad
        Q = N\sum_{\tau=0}^{M} r_{\varepsilon u}(\tau)^2\sim\chi^2_{M+1-\mathrm{ddof}}

    (Box & Jenkins 1976, sec. 11.3; Ljung 1999, sec. 16.6), band
    :math:`z_{1-\alpha/2}/\sqrt N`.

    Returns
    -------
    dict
        ``lags`` (2M + 1,), ``ccf``, ``band``, ``q_stat``, ``dof``, ``p_value``.
    """
    uc, ssu = _centre(u)
    ec, sse = _centre(e)
    N = ec.size
    den = np.sqrt(ssu * sse)
    lags = np.arange(-max_lag, max_lag + 1)
    ccf = np.array([(ec[t:] @ uc[:N - t]) / den if t >= 0 else (ec[:N + t] @ uc[-t:]) / den
                    for t in lags])
    q = float(N * np.sum(ccf[max_lag:] ** 2))
    dof = max_lag + 1 - ddof
    return {"lags": lags, "ccf": ccf, "band": float(stats.norm.ppf(1 - alpha / 2) / np.sqrt(N)),
            "q_stat": q, "dof": dof, "p_value": float(stats.chi2.sf(q, dof))}


def fit_percent(y, y_hat):
    r"""MATLAB's normalised fit :math:`100(1 - \|y-\hat y\|/\|y-\bar y\|)` per column.

    The caller validates the shapes; a constant ``y`` gives −inf or NaN.
    """
    y = np.asarray(y, dtype=np.float64)
    y_hat = np.asarray(y_hat, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        out = 100.0 * (1.0 - np.linalg.norm(y - y_hat, axis=0)
                       / np.linalg.norm(y - y.mean(axis=0), axis=0))
    return float(out) if np.ndim(out) == 0 else out


def t_table(theta, stderr, dof, alpha=0.05):
    r"""t statistics θ/se, two-sided p-values :math:`2P(T_{dof} > |t|)` and (1 − α) limits.

    Returns
    -------
    tvalues, pvalues, lower, upper : ndarray, shape like ``theta``
    """
    theta = np.asarray(theta, dtype=np.float64)
    stderr = np.asarray(stderr, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = theta / stderr
        p = 2.0 * stats.t.sf(np.abs(t), dof) if dof > 0 else np.full(t.shape, np.nan)
        q = stats.t.ppf(1 - alpha / 2, dof) if dof > 0 else np.nan
    return t, p, theta - q * stderr, theta + q * stderr

r"""Summary tables of fitted input–output models and of recursive fits."""

from __future__ import annotations

import numpy as np

from .._summary import Summary, parameter_rows
from .._teststats import cross_correlation, fit_percent, gaussian_llf, information_criteria, ljung_box
from .._validation import as_float_array, check_int, check_scalar, param_error

__all__ = ["model_summary", "recursive_summary"]


def _lags(max_lag, N):
    return min(check_int(max_lag, "max_lag", low=1), N - 1)


def model_summary(model, *, alpha=0.05, max_lag=25):
    r"""Summary table of a fitted input–output model (ARX, ARMAX, OE, …).

    Any fitted model plugs in that provides ``theta`` (d,), ``cov`` (d, d),
    ``names`` (d), ``residuals`` (the prediction errors of the fit's rows,
    shape (N,)), ``index`` (their sample positions), ``predict(y, u, k)``,
    ``simulate(u)`` and the estimation record ``_fit_signals = (y, U)``
    that :class:`~adaptid.models.ARX`'s base class stores at fit time.

    With N the number of prediction errors εₖ, d the number of parameters,
    SSR = Σεₖ² and V = SSR/N:

    * stderr √diag(cov), t = θ/se, p = ``2P(T_{N−d} > |t|)``, the (1 − α)
      limits θ ± t_{1−α/2, N−d}·se;
    * σ̂² = SSR/(N − d), ℓ = −N/2 (log 2π + log V + 1), AIC = −2ℓ + 2d,
      BIC = −2ℓ + d log N, FPE = V(1 + d/N)/(1 − d/N) (Ljung 1999, eq. 16.31);
      the one definition of AIC and FPE in adaptid, also in
      :func:`~adaptid.models.select_order`'s table. That table's N is the
      grid's common rows, so its AIC for a structure is the one of
      ``OrderSelection.model()``'s summary (fitted on those rows); a model
      fitted on the whole record has more rows, so a larger N and AIC;
    * fit % (MATLAB's NRMSE) of the one-step prediction and of the
      simulation on the estimation record (zero initial conditions);
    * the Ljung–Box p-value of εₖ and, per input, the p-value of the
      residual–input cross-correlation test over lags 0 … M
      (:func:`adaptid.diagnostics.autocorrelation_test` and
      :func:`~adaptid.diagnostics.cross_correlation_test` give the same).

    Parameters
    ----------
    model : fitted model
    alpha : float
        Level of the limits and of the two tests (default 0.05).
    max_lag : int
        M of the residual tests (default 25, capped at N − 1).

    Returns
    -------
    adaptid._summary.Summary
    """
    alpha = check_scalar(alpha, "alpha", low=0.0, high=1.0, low_open=True, high_open=True)
    if getattr(model, "theta", None) is None:
        raise param_error("model", "a fitted model (call fit first)", model)
    theta = np.asarray(model.theta, dtype=np.float64).ravel()
    d = theta.size
    eps = np.asarray(model.residuals, dtype=np.float64).ravel()
    N = eps.size
    ssr = float(eps @ eps)
    dof = N - d
    stderr = np.sqrt(np.clip(np.diag(np.asarray(model.cov)), 0.0, None))
    llf = gaussian_llf(ssr, N)
    ic = information_criteria(llf, N, d, loss=ssr / N)
    st = {"N": N, "parameters": d, "dof": dof, "sigma^2": ssr / dof if dof > 0 else float("nan"),
          "loss V": ssr / N, "log-likelihood": llf, "AIC": ic["aic"], "BIC": ic["bic"],
          "FPE": ic["fpe"]}
    y, U = model._fit_signals
    y_name = getattr(model, "y_name", "y")
    u_names = tuple(getattr(model, "u_names", ())) or tuple(f"u{i + 1}" for i in range(U.shape[1]))
    bounds = getattr(model, "_fit_bounds", None)
    if bounds is not None and len(bounds) > 2:
        st["experiments"] = len(bounds) - 1
    if getattr(model, "n_dropped", 0):
        st["rows left out (NaN)"] = int(model.n_dropped)
    if np.nanmax(y) > np.nanmin(y):
        st.update(_estimation_fits(model, y, U, bounds))
    M = _lags(max_lag, N)
    if np.ptp(eps) > 0:
        lb = ljung_box(eps, M, alpha)
        st[f"Ljung-Box p (lags 1..{M})"] = lb["p_value"]
        idx = np.asarray(model.index)
        for j, name in enumerate(u_names):
            uj = U[idx, j]
            if np.ptp(uj) > 0:
                p_cc = cross_correlation(uj, eps, M, alpha)["p_value"]
                st[f"cross-corr. p ({name}, lags 0..{M})"] = p_cc
    orders = ", ".join(f"{k}={getattr(model, k)}" for k in getattr(model, "_order_names", ()))
    title = f"{type(model).__name__}({orders}), dt={getattr(model, 'dt', 1.0):g}"
    notes = (f"output: {y_name}; inputs: {', '.join(u_names) or 'none'}",
             "sigma^2 = SSR/(N - d); AIC, BIC from the Gaussian likelihood at V = SSR/N")
    return Summary(title=title, names=tuple(model.names),
                   params=parameter_rows(theta, stderr, dof, alpha), stats=st, alpha=alpha,
                   notes=notes)


def _estimation_fits(model, y, U, bounds):
    """fit % of the 1-step prediction and the simulation on the estimation record,
    experiment by experiment (each from zero initial conditions), gaps left out."""
    from ._segments import complete_runs

    N = y.shape[0]
    bounds = np.array([0, N]) if bounds is None or bounds[-1] != N else bounds
    ok = ~(np.isnan(y) | np.isnan(U).any(axis=1))
    runs = [(0, N)] if ok.all() and len(bounds) == 2 else complete_runs(ok, bounds)
    y1, ys = np.full(N, np.nan), np.full(N, np.nan)
    for a, b in runs:
        Ue = U[a:b]
        y1[a:b] = model.predict(y[a:b], Ue if U.shape[1] else None, k=1)
        if U.shape[1]:
            ys[a:b] = model.simulate(Ue)
    out = {}
    keep = np.isfinite(y1)
    out["fit % (1-step, estimation)"] = fit_percent(y[keep], y1[keep])
    if U.shape[1]:
        keep = np.isfinite(ys)
        out["fit % (simulation, estimation)"] = fit_percent(y[keep], ys[keep])
    return out


def recursive_summary(est, Phi, y, *, names=None, alpha=0.05, max_lag=25, weights=None,
                      forgetting=None, used=None):
    r"""Summary table of a recursive fit, from :func:`adaptid.recursive_fit_stats`.

    σ̂², the standard errors, the degrees of freedom Σcₖ − n and the SSR are
    those of :func:`adaptid.recursive_fit_stats` (the project's one rule
    for a recursive fit, with the factor cₖ of each sample in the
    estimator's cost: forgetting, window); from them t = θ/se with p-values
    and limits from Student's t with Σcₖ − n degrees of freedom (not an
    integer under forgetting), ℓ = −nₑ/2 (log 2π + log(SSR/nₑ) + 1) with
    nₑ = Σcₖ, AIC = −2ℓ + 2n, BIC = −2ℓ + n log nₑ, and the Ljung–Box
    p-value of the final estimate's residuals :math:`y_k - \varphi_k^T\hat\theta_N`
    over the samples used (meaningful when the parameters are constant).

    Parameters
    ----------
    est : RLS, SlidingWindowRLS or KalmanRLS
        After its run over (Phi, y).
    Phi : array_like, shape (N, n); or pandas DataFrame (its columns name the parameters)
    y : array_like, shape (N,)
    names : sequence of str, length n, optional
    alpha : float
        Level of the limits and of the test (default 0.05).
    max_lag : int
        Lags of the Ljung–Box test (default 25, capped at N − 1).
    weights, forgetting, used : optional
        As for :func:`adaptid.recursive_fit_stats`.

    Returns
    -------
    adaptid._summary.Summary

    Examples
    --------
    >>> import numpy as np, adaptid
    >>> from adaptid.models import recursive_summary
    >>> rng = np.random.default_rng(0)
    >>> Phi = np.column_stack([np.ones(200), rng.standard_normal(200)])
    >>> y = Phi @ [1.0, 2.0] + 0.1 * rng.standard_normal(200)
    >>> est = adaptid.RLS(2, P0=1e8); _ = est.run(Phi, y)
    >>> s = recursive_summary(est, Phi, y, names=["c", "x"])
    >>> bool(np.allclose(s.params[:, 1], adaptid.lstsq(Phi, y).stderr, rtol=1e-5))
    True
    """
    from ..estimators import recursive_fit_stats

    alpha = check_scalar(alpha, "alpha", low=0.0, high=1.0, low_open=True, high_open=True)
    if names is None and hasattr(Phi, "columns"):
        names = tuple(str(c) for c in Phi.columns)
    Phi = as_float_array(getattr(Phi, "to_numpy", lambda: Phi)(), "Phi", ndim=2, finite=False)
    y = as_float_array(getattr(y, "to_numpy", lambda: y)(), "y", ndim=1, finite=False)
    fs = recursive_fit_stats(est, Phi, y, weights=weights, forgetting=forgetting, used=used)
    theta = np.asarray(est.theta, dtype=np.float64).ravel()
    n = theta.size
    names = tuple(f"theta{i}" for i in range(n)) if names is None else tuple(str(v) for v in names)
    if len(names) != n:
        raise param_error("names", f"of length n={n}", f"<length {len(names)}>")
    llf = gaussian_llf(fs.ssr, fs.n_eff)
    ic = information_criteria(llf, fs.n_eff, n, loss=fs.ssr / fs.n_eff)
    st = {"method": type(est).__name__, "N": y.size, "N effective": fs.n_eff, "dof": fs.dof,
          "sigma^2": fs.sigma2, "SSR": fs.ssr, "log-likelihood": llf, "AIC": ic["aic"],
          "BIC": ic["bic"], "FPE": ic["fpe"]}
    ok = np.isfinite(Phi).all(axis=1) & np.isfinite(y)
    if used is not None:
        ok &= np.asarray(used, dtype=bool)
    r = y[ok] - Phi[ok] @ theta
    if r.size > 2 and np.ptp(r) > 0:
        M = _lags(max_lag, r.size)
        st[f"Ljung-Box p (lags 1..{M})"] = ljung_box(r, M, alpha)["p_value"]
    return Summary(title=f"Recursive fit ({type(est).__name__})", names=names,
                   params=parameter_rows(theta, fs.stderr, fs.dof, alpha), stats=st, alpha=alpha,
                   notes=("sigma^2, stderr, dof: adaptid.recursive_fit_stats (one rule for every "
                          "recursive fit)",))

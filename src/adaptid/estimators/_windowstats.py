r"""Per-sample statistics of the current window: ``run(..., stats=True)``.

The compiled streams (:mod:`adaptid._kernels.recursions._rollstats`) keep, per sample,
the sums of the data in the cost; this module turns them into the
statistics of :class:`WindowStats`, with the one σ̂² rule of
:func:`adaptid.recursive_fit_stats` (:func:`._sigma2.sigma2_rule`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._kernels.recursions._rollstats import HEAD
from ._sigma2 import sigma2_rule

__all__ = ["WindowStats", "detect_constant", "window_stats"]


@dataclass(frozen=True, eq=False)
class WindowStats:
    r"""Statistics of the data in the estimator's cost after every sample.

    For :class:`~adaptid.SlidingWindowRLS` the data are the (up to) M samples
    of the window after sample k; for :class:`~adaptid.RLS` all samples so
    far. Each sample i enters with the weight :math:`c_i w_i`, where
    :math:`w_i` is its weight and :math:`c_i = \prod_{l=i+1}^{k}\lambda_l` its
    forgetting factor (1 without forgetting; :func:`adaptid.sample_factors`).
    With :math:`n_\mathrm{eff} = \sum_i c_i`, :math:`r_i = y_i -
    \varphi_i^T\hat\theta_k` and n parameters:

    .. math::

        \mathrm{ssr} &= \sum_i c_i w_i r_i^2 + \Big(\prod_{l\le k}\lambda_l\Big)
            (\hat\theta_k-\theta_0)^T P_0^{-1}(\hat\theta_k-\theta_0),\qquad
        \hat\sigma^2 = \frac{\mathrm{ssr}}{n_\mathrm{eff} - n},\\
        \mathrm{se}_j &= \sqrt{\hat\sigma^2 P_{jj}},\qquad
        t_j = \hat\theta_j/\mathrm{se}_j,\\
        R^2 &= 1 - \mathrm{ssr}/\mathrm{TSS},\qquad
        \bar R^2 = 1 - \frac{n_\mathrm{eff} - k_c}{n_\mathrm{eff} - n}(1 - R^2),\\
        \ell &= -\frac{n_\mathrm{eff}}{2}\Big(1 + \log 2\pi
            + \log\frac{\mathrm{ssr}}{n_\mathrm{eff}}\Big)
            + \frac12\sum_i c_i\log w_i,\\
        \mathrm{AIC} &= -2\ell + 2n,\qquad \mathrm{BIC} = -2\ell + n\log n_\mathrm{eff},

    with TSS the centred :math:`\sum_i c_iw_i(y_i-\bar y)^2`, :math:`\bar y =
    \sum_i c_iw_iy_i/\sum_i c_iw_i`, when the regressors hold a constant
    (:math:`k_c = 1`) and the uncentred :math:`\sum_i c_iw_iy_i^2` otherwise.
    Without forgetting these are exactly statsmodels' ``RollingOLS`` /
    ``RollingWLS`` (``nobs``, ``ssr``, ``mse_resid``, ``bse``, ``tvalues``,
    ``rsquared``, ``rsquared_adj``, ``llf``, ``aic``, ``bic``; its WLS
    likelihood includes :math:`\frac12\sum\log w_i`, −∞ if a weight in the
    window is 0) and σ̂² is that of :func:`adaptid.recursive_fit_stats`;
    with forgetting each is the same formula with the forgetting-weighted
    sums (:math:`\ell` is the exponentially weighted log-likelihood
    :math:`\sum_i c_i \ell_i` maximised over σ²). The prior term of ssr and
    the prior in P vanish with an exact diffuse start (``P0="diffuse"``): the
    statistics are then those of the least-squares fit of the window (or of
    all samples so far) alone, statsmodels' values to rounding; with
    ``P0 = 1e12`` and data of order 1 the prior changes them in about the
    12th digit. With ``P0="diffuse"``, where θ is not yet identified (the
    weighted information matrix of the window is rank-deficient, e.g. fewer
    than n samples) ssr, σ̂², the standard errors, t values, R², adjusted R²,
    ℓ, AIC and BIC are NaN; statsmodels' ``RollingOLS`` is NaN where fewer
    than n samples are in the window (its ``min_nobs``), and in a
    rank-deficient window with n samples or more it reports the values of a
    pseudo-inverse fit, which are not compared.
    Where :math:`n_\mathrm{eff} \le n` (no degrees of freedom) σ̂², the
    standard errors, t values, R², adjusted R², ℓ, AIC and BIC are NaN.
    Skipped samples (``nan_policy="skip"``) repeat the previous row.

    ssr is kept recursively (:mod:`adaptid._kernels.recursions._rollstats`): adding a
    sample, :math:`J_k = \lambda_k J_{k-1} + w_k e_k\varepsilon_k` (a-priori
    and a-posteriori errors; Ljung & Söderström 1983, ch. 2); removing one
    from the window, :math:`J \leftarrow J - c\,r^2/(1 - c\,\varphi^TP\varphi)`
    (Sherman–Morrison), recomputed from the buffer when the window is
    re-solved; ȳ and the centred sum by West's (1979) weighted update and
    its reverse; diag P from the U-D factors.

    References
    ----------
    .. [1] L. Ljung, T. Söderström, *Theory and Practice of Recursive
       Identification*, MIT Press, 1983.
    .. [2] D. H. D. West, "Updating mean and variance estimates: an improved
       method", *Comm. ACM* 22(9), 532–535, 1979.
    .. [3] statsmodels, ``statsmodels/regression/rolling.py`` (RollingWLS).

    Attributes
    ----------
    nobs : ndarray of int, shape (N,)
        Samples in the cost (skipped samples not counted).
    n_eff : ndarray, shape (N,)
        :math:`\sum_i c_i` (= ``nobs`` without forgetting).
    ssr, sigma2, rsquared, rsquared_adj, llf, aic, bic : ndarray, shape (N,) or (N, p)
        Per output when the estimator has p outputs.
    stderr, tvalues : ndarray, shape (N, n) or (N, n, p)
    centered_tss, uncentered_tss : ndarray, shape (N,) or (N, p)
    k_constant : int
        1 when the regressors hold a constant (statsmodels' detection, or
        the ``has_constant`` given to ``run``), else 0.

    All arrays carry a leading axis B after ``run_batched``.

    Examples
    --------
    >>> import numpy as np, adaptid
    >>> rng = np.random.default_rng(0)
    >>> X = np.column_stack([np.ones(100), rng.standard_normal(100)])
    >>> y = X @ [1.0, 2.0] + 0.1 * rng.standard_normal(100)
    >>> st = adaptid.SlidingWindowRLS(2, 20, P0=1e12).run(X, y, stats=True).stats
    >>> st.nobs[[0, 19, 99]].tolist(), st.k_constant
    ([1, 20, 20], 1)
    >>> bool(np.isclose(st.sigma2[-1], st.ssr[-1] / (20 - 2)))
    True
    """

    nobs: np.ndarray
    n_eff: np.ndarray
    ssr: np.ndarray
    sigma2: np.ndarray
    stderr: np.ndarray
    tvalues: np.ndarray
    rsquared: np.ndarray
    rsquared_adj: np.ndarray
    llf: np.ndarray
    aic: np.ndarray
    bic: np.ndarray
    centered_tss: np.ndarray
    uncentered_tss: np.ndarray
    k_constant: int

    def __repr__(self) -> str:
        return f"WindowStats(N={self.nobs.shape[-1]}, k_constant={self.k_constant})"

    def with_labels(self, names=None, time=None) -> "WindowStats":
        """Attach the parameter names and time axis of the data (for :meth:`to_pandas`)."""
        object.__setattr__(self, "_names", None if names is None else tuple(names))
        object.__setattr__(self, "_time", time)
        return self

    @property
    def df_resid(self) -> np.ndarray:
        """Residual degrees of freedom n_eff − n per sample (NaN where ≤ 0)."""
        n = self.stderr.shape[-1] if self.stderr.ndim == self.nobs.ndim + 1 else \
            self.stderr.shape[-2]
        dof = self.n_eff - n
        return np.where(dof > 0, dof, np.nan)

    def _dof(self):
        """df_resid shaped to broadcast against stderr/tvalues."""
        extra = self.tvalues.ndim - self.nobs.ndim
        return self.df_resid.reshape(self.df_resid.shape + (1,) * extra)

    @property
    def pvalues(self) -> np.ndarray:
        r"""Two-sided p-values of :math:`t_j` per sample, Student's t with n_eff − n dof.

        :math:`p = 2\,P(T_{\nu} > |t_j|)`, ν = n_eff − n: statsmodels'
        ``RollingOLS(...).fit(use_t=True).pvalues`` without forgetting (and
        ``OLS`` on each window). NaN where there are no degrees of freedom.
        """
        from scipy import stats

        with np.errstate(invalid="ignore"):
            return 2.0 * stats.t.sf(np.abs(self.tvalues), self._dof())

    def conf_int(self, alpha=0.05):
        r"""Per-sample confidence intervals θ̂ ± t_{1−α/2, ν}·se: arrays ``(lower, upper)``.

        ``theta`` is not stored here: the interval is built from t = θ̂/se,
        θ̂ = t·se (exact where se > 0).
        """
        from scipy import stats

        from .._validation import check_scalar

        alpha = check_scalar(alpha, "alpha", low=0.0, high=1.0, low_open=True, high_open=True)
        q = stats.t.ppf(1.0 - alpha / 2.0, self._dof())
        theta = self.tvalues * self.stderr
        return theta - q * self.stderr, theta + q * self.stderr

    def to_pandas(self):
        """The statistics as a pandas DataFrame, one row per sample.

        Columns ``nobs``, ``n_eff``, ``df_resid``, ``ssr``, ``sigma2``,
        ``rsquared``, ``rsquared_adj``, ``llf``, ``aic``, ``bic``, then per
        parameter ``stderr[name]``, ``tvalues[name]``, ``pvalues[name]``
        (names from the DataFrame given to ``run``, else ``theta[j]``);
        indexed by the time axis of the data when it had one. One stream
        and one output only.
        """
        import pandas as pd

        if self.nobs.ndim != 1 or self.ssr.ndim != 1:
            raise ValueError("to_pandas is for one stream with one output (index the "
                             "batched or multi-output arrays instead)")
        n = self.stderr.shape[1]
        given, time = getattr(self, "_names", None), getattr(self, "_time", None)
        names = list(given) if given is not None else [f"theta[{j}]" for j in range(n)]
        cols = {k: getattr(self, k) for k in ("nobs", "n_eff", "df_resid", "ssr", "sigma2",
                                                "rsquared", "rsquared_adj", "llf", "aic", "bic")}
        pv = self.pvalues
        for what, arr in (("stderr", self.stderr), ("tvalues", self.tvalues), ("pvalues", pv)):
            for j, name in enumerate(names):
                cols[f"{what}[{name}]"] = arr[:, j]
        index = pd.Index(time, name="time") if time is not None else \
            pd.RangeIndex(self.nobs.shape[0], name="sample")
        return pd.DataFrame(cols, index=index)

    to_frame = to_pandas


def detect_constant(Phi) -> int:
    """1 if the regressors hold a constant, as statsmodels decides (``base/data.py``).

    A column constant over the finite rows and not zero is a constant;
    otherwise an implicit one counts when adding a column of ones does not
    raise the rank of Φ (e.g. dummies that sum to one).
    """
    X = np.asarray(Phi, dtype=np.float64).reshape(-1, np.shape(Phi)[-1])
    X = X[np.isfinite(X).all(axis=1)]
    if X.shape[0] == 0:
        return 0
    const = (X.max(axis=0) == X.min(axis=0)) & (X[0] != 0)
    if const.any():
        return 1
    aug = np.column_stack([np.ones(X.shape[0]), X])
    return int(np.linalg.matrix_rank(aug) == np.linalg.matrix_rank(X))


def window_stats(St, theta, n, p, k_constant, single) -> WindowStats:
    """The statistics from the kernel's rows ``St`` (..., N, K) and θ (..., N, n, p)."""
    count, n_eff, W, logw, zeros = (St[..., i] for i in range(HEAD))
    diag = St[..., HEAD:HEAD + n]
    o = HEAD + n
    ssr = St[..., o:o + p]
    mean = St[..., o + p:o + 2 * p]
    ctss = St[..., o + 2 * p:o + 3 * p]
    utss = ctss + W[..., None] * mean * mean
    sigma2, stderr = sigma2_rule(ssr, n_eff, n, diag)
    ne = n_eff[..., None]
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        tvalues = theta / stderr
        rsq = 1.0 - ssr / (ctss if k_constant else utss)
        dof = ne - n
        rsq_adj = np.where(dof > 0, 1.0 - (ne - k_constant) / np.where(dof > 0, dof, 1.0)
                           * (1.0 - rsq), np.nan)
        llf = -0.5 * ne * (1.0 + np.log(2.0 * np.pi) + np.log(ssr / ne)) + 0.5 * logw[..., None]
        llf = np.where(zeros[..., None] > 0, -np.inf, llf)
        llf = np.where(dof > 0, llf, np.nan)
        aic = -2.0 * llf + 2.0 * n
        bic = -2.0 * llf + np.log(ne) * n
    out = {"ssr": ssr, "sigma2": sigma2, "stderr": stderr, "tvalues": tvalues,
           "rsquared": np.where(dof > 0, rsq, np.nan), "rsquared_adj": rsq_adj, "llf": llf,
           "aic": aic, "bic": bic, "centered_tss": ctss, "uncentered_tss": utss}
    if single:
        out = {k: v[..., 0] for k, v in out.items()}
    return WindowStats(nobs=np.rint(count).astype(np.int64), n_eff=n_eff.copy(),
                       k_constant=int(k_constant), **out)


def check_stats(est, stats, has_constant) -> bool:
    """Validate ``stats`` and ``has_constant`` of a run; True when statistics are asked for."""
    from .._validation import param_error
    if not isinstance(stats, (bool, np.bool_)):
        raise param_error("stats", "True or False", stats)
    if has_constant is not None and not isinstance(has_constant, (bool, np.bool_)):
        raise param_error("has_constant", "None, True or False", has_constant)
    if has_constant is not None and not stats:
        raise param_error("has_constant", "None unless stats=True", has_constant)
    if stats and est._variant not in est.spec.stats:
        raise param_error("stats", f"False for {type(est).__name__} with these options "
                          "(windowed statistics: SlidingWindowRLS, and RLS with constant or "
                          "per-sample exponential forgetting and no P_max)", stats)
    return bool(stats)


def stats_rows(est, shape_N, want):
    """The kernels' ``St``: (..., N + 1, K) with row 0 the sums so far, or None."""
    from .._kernels.recursions._rollstats import width
    lead = shape_N[:-1]
    if not want:
        return None  # the kernels' statistics hooks then compile to nothing
    St = np.zeros(lead + (shape_N[-1] + 1, width(est.n_params, est.n_outputs)))
    if est.spec.stats_from_buffer or est.n_updates == 0:
        return St  # the window's kernel sums its buffer; RLS from the prior: all zero
    acc = getattr(est, "_stats_acc", None)
    if acc is None or est._stats_mark != (est.n_updates, est._batch):
        raise ValueError(
            f"run(..., stats=True): this {type(est).__name__} has seen samples outside runs "
            "with stats=True, whose sums its state does not keep; call reset() and run "
            "all the data with stats=True")
    St[..., 0, :] = acc
    return St


def finish_stats(est, St, Th, Phi, has_constant, identified=None):
    """WindowStats of a run; remembers the last sums for the next run. ``identified``
    (the kernels' per-sample flags of a diffuse start, or None): where 0 the
    statistics of the fit are NaN (see :class:`WindowStats`)."""
    est._stats_acc = St[..., -1, :].copy()
    est._stats_mark = (est.n_updates, est._batch)
    kc = detect_constant(Phi) if has_constant is None else int(bool(has_constant))
    ws = window_stats(St[..., 1:, :], Th, est.n_params, est.n_outputs, kc, est._single)
    if identified is None or np.all(identified != 0.0):
        return ws
    bad = np.asarray(identified) == 0.0
    for name in _FIT_FIELDS:
        a = getattr(ws, name)
        a[bad] = np.nan
    return ws


#: the statistics that need θ determined by the data (NaN before, with P0="diffuse")
_FIT_FIELDS = ("ssr", "sigma2", "stderr", "tvalues", "rsquared", "rsquared_adj", "llf", "aic",
               "bic")

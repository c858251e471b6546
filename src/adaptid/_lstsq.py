r"""Batch (weighted, ridge) least squares by QR."""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from scipy import linalg

from ._exceptions import PrecisionWarning
from ._lazy import lazy
from ._validation import as_float_array, check_scalar, param_error

stats = lazy("scipy.stats")

__all__ = ["lstsq", "LSResult"]


@dataclass(frozen=True, eq=False)
class LSResult:
    r"""Result of :func:`lstsq`.

    Attributes
    ----------
    theta : ndarray, shape (n,) or (n, p)
        The estimate (an ndarray whatever the inputs were).
    residuals : ndarray, shape (N,) or (N, p)
        :math:`y - \Phi\hat\theta` (unweighted; an ndarray whatever the
        inputs were).
    sigma2 : float or ndarray, shape (p,)
        :math:`\hat\sigma^2 = \sum_k w_k r_k^2 / (N - n)`.
    dof : int
        Residual degrees of freedom N − n.
    rank : int
        Numerical rank of the (weighted, augmented) design.

    Notes
    -----
    When ``Phi`` was a pandas DataFrame, the statsmodels-named statistics
    come labelled, as statsmodels' OLS / WLS results do: :attr:`params`,
    :attr:`stderr` (:attr:`bse`), :attr:`tvalues` and :attr:`pvalues` are
    Series indexed by the columns of ``Phi`` (DataFrames with one column per
    output for several outputs), :meth:`conf_int` is a DataFrame with columns
    0 and 1, and :attr:`resid` and :attr:`fittedvalues` are Series indexed
    by the rows of ``Phi``. With arrays they are arrays, as before.
    """

    theta: np.ndarray
    residuals: np.ndarray
    sigma2: np.ndarray
    dof: int
    rank: int
    _R: np.ndarray = field(repr=False)
    _single: bool = field(repr=False, default=True)
    _y: np.ndarray | None = field(repr=False, default=None)          # (N, p) as given
    _weights: np.ndarray | None = field(repr=False, default=None)    # (N,) or None
    _k_constant: int = field(repr=False, default=0)
    names: tuple | None = field(repr=False, default=None)
    _columns: object = field(repr=False, default=None)   # pandas Index of Phi's columns
    _rows: object = field(repr=False, default=None)      # pandas Index of Phi's rows
    _outputs: object = field(repr=False, default=None)   # y's columns (several outputs)

    # ------------------------------------------------- pandas in, pandas out
    def _by_param(self, arr):
        """``arr`` (n,) or (n, p) as a Series / DataFrame by Phi's columns when Phi was one."""
        if self._columns is None:
            return arr
        import pandas as pd

        if np.ndim(arr) == 1:
            return pd.Series(arr, index=self._columns)
        return pd.DataFrame(arr, index=self._columns, columns=self._outputs)

    def _by_row(self, arr):
        """``arr`` (N,) or (N, p) as a Series / DataFrame by Phi's rows when Phi was a DataFrame."""
        if self._columns is None:
            return arr
        import pandas as pd

        if np.ndim(arr) == 1:
            return pd.Series(arr, index=self._rows)
        return pd.DataFrame(arr, index=self._rows, columns=self._outputs)

    # ---------------------------------------------------- statsmodels' names
    def _need_data(self, what):
        if self._y is None:
            raise ValueError(f"{what} needs the data of the fit (a result made by adaptid.lstsq)")

    @property
    def nobs(self) -> int:
        """Number of observations N."""
        return int(self.residuals.shape[0])

    @property
    def params(self):
        """The estimate (statsmodels' name for :attr:`theta`); a Series for a DataFrame ``Phi``."""
        return self._by_param(self.theta)

    @property
    def bse(self):
        """Standard errors (statsmodels' name for :attr:`stderr`)."""
        return self.stderr

    @property
    def resid(self):
        r"""Residuals :math:`y - \Phi\hat\theta` (statsmodels' name).

        A Series on the rows of a DataFrame ``Phi``, else :attr:`residuals`.
        """
        return self._by_row(self.residuals)

    @property
    def fittedvalues(self):
        r""":math:`\Phi\hat\theta` at the data (statsmodels' name).

        A Series on the rows of a DataFrame ``Phi``, else an array like ``y``.
        """
        self._need_data("fittedvalues")
        with np.errstate(over="ignore", invalid="ignore"):
            fitted = (self._y[:, 0] if self._single else self._y) - self.residuals
        return self._by_row(fitted)

    @property
    def df_resid(self) -> int:
        """Residual degrees of freedom N − n (statsmodels' ``df_resid``)."""
        return self.dof

    @property
    def df_model(self) -> int:
        """n minus the number of constant columns (statsmodels' ``df_model``)."""
        return self.rank - self._k_constant

    @cached_property
    def ssr(self):
        r"""Weighted sum of squared residuals :math:`\sum_k w_k r_k^2` (per output)."""
        r2 = np.asarray(self.residuals) ** 2
        if self._weights is not None:
            r2 = r2 * (self._weights if r2.ndim == 1 else self._weights[:, None])
        with np.errstate(over="ignore"):
            out = r2.sum(axis=0)
        return float(out) if self._single else out

    @cached_property
    def _tvalues(self) -> np.ndarray:
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.asarray(self.theta) / self._stderr

    @property
    def tvalues(self):
        """t statistics θ̂/se, shape like ``theta``; a Series for a DataFrame ``Phi``."""
        return self._by_param(self._tvalues)

    @cached_property
    def _pvalues(self) -> np.ndarray:
        if self.dof <= 0:
            return np.full(np.shape(self.theta), np.nan)
        return 2.0 * stats.t.sf(np.abs(self._tvalues), self.dof)

    @property
    def pvalues(self):
        """Two-sided p-values of the t statistics, Student's t with N − n dof.

        Shape like ``theta``; a Series for a DataFrame ``Phi``.
        """
        return self._by_param(self._pvalues)

    @cached_property
    def _tss(self):
        self._need_data("rsquared")
        Y = self._y
        w = np.ones(Y.shape[0]) if self._weights is None else self._weights
        if self._k_constant:
            mean = (w @ Y) / w.sum()
            tss = w @ ((Y - mean) ** 2)
        else:
            tss = w @ (Y ** 2)
        return tss[0] if self._single else tss

    @cached_property
    def rsquared(self):
        r"""Coefficient of determination, statsmodels' rule.

        :math:`1 - \mathrm{SSR}/\mathrm{TSS}`, TSS centred (weighted mean)
        when Φ has a constant column, uncentred otherwise.
        """
        with np.errstate(divide="ignore", invalid="ignore"):
            out = 1.0 - self.ssr / self._tss
        return float(out) if self._single else out

    @cached_property
    def rsquared_adj(self):
        r"""Adjusted R²: :math:`1 - \frac{N - k_c}{N - n}(1 - R^2)`, k_c constant columns."""
        with np.errstate(divide="ignore", invalid="ignore"):
            # dof = 0 (a saturated fit, N == n): undefined, NaN as statsmodels
            ratio = (self.nobs - self._k_constant) / self.dof if self.dof > 0 else np.nan
            out = 1.0 - ratio * (1.0 - np.asarray(self.rsquared))
        return float(out) if self._single else out

    @cached_property
    def llf(self):
        r"""Gaussian log-likelihood at the ML variance (statsmodels' OLS / WLS ``llf``).

        .. math::

            \ell = -\frac N2\left(\log 2\pi + \log\frac{\mathrm{SSR}}{N} + 1\right)
                   + \frac12\sum_k \log w_k .
        """
        from ._teststats import gaussian_llf

        lw = 0.0
        if self._weights is not None:
            with np.errstate(divide="ignore"):
                lw = float(np.sum(np.log(self._weights)))
        return gaussian_llf(self.ssr, self.nobs, log_weights=lw)

    @property
    def aic(self):
        r"""Akaike's criterion :math:`-2\ell + 2n` (statsmodels' ``aic``)."""
        from ._teststats import information_criteria

        return information_criteria(self.llf, self.nobs, self.rank)["aic"]

    @property
    def bic(self):
        r"""Schwarz's criterion :math:`-2\ell + n\log N` (statsmodels' ``bic``)."""
        from ._teststats import information_criteria

        return information_criteria(self.llf, self.nobs, self.rank)["bic"]

    def summary(self, names=None, *, alpha=0.05):
        r"""The regression table: estimates with stderr, t, p, limits; N, dof, σ̂², R², ℓ, AIC, BIC.

        Parameters
        ----------
        names : sequence of str, length n, optional
            Parameter names (default: the columns of a DataFrame ``Phi``,
            else ``theta0, theta1, …``).
        alpha : float
            Level of the confidence limits (default 0.05).

        Returns
        -------
        adaptid._summary.Summary
            ``str()`` gives the text table, ``_repr_html_`` the notebook one.
        """
        from ._summary import Summary, parameter_rows

        alpha = check_scalar(alpha, "alpha", low=0.0, high=1.0, low_open=True, high_open=True)
        if not self._single:
            raise ValueError("summary is for a single output: call lstsq per column of y")
        n = np.size(self.theta)
        names = tuple(names) if names is not None else (
            self.names if self.names is not None else tuple(f"theta{i}" for i in range(n)))
        if len(names) != n:
            raise param_error("names", f"of length n={n}", f"<length {len(names)}>")
        st = {"N": self.nobs, "dof": self.dof, "sigma^2": self.sigma2, "SSR": self.ssr}
        if self._y is not None:
            st.update({"R^2": self.rsquared, "adj. R^2": self.rsquared_adj,
                       "log-likelihood": self.llf, "AIC": self.aic, "BIC": self.bic})
        kind = "Least squares" if self._weights is None else "Weighted least squares"
        return Summary(title=f"{kind} (QR)", names=names,
                       params=parameter_rows(self.theta, self._stderr, self.dof, alpha),
                       stats=st, alpha=alpha)

    @cached_property
    def _Rinv(self) -> np.ndarray:
        n = self._R.shape[0]
        return linalg.solve_triangular(self._R, np.eye(n), lower=False)

    @cached_property
    def unscaled_cov(self) -> np.ndarray:
        r"""(ΦᵀWΦ + ridge·I)⁻¹ = R⁻¹R⁻ᵀ, shape (n, n), from the triangular factor."""
        Ri = self._Rinv
        with np.errstate(over="ignore"):  # a tiny design: inf is the honest answer
            return Ri @ Ri.T

    @cached_property
    def cov(self) -> np.ndarray:
        r"""σ̂²(ΦᵀWΦ + ridge·I)⁻¹: shape (n, n), or (p, n, n) for p outputs."""
        s = np.sqrt(np.asarray(self.sigma2))
        Ri = self._Rinv
        with np.errstate(over="ignore", invalid="ignore"):  # σ̂ = 0 gives 0, not 0·inf; σ̂ = inf: inf/NaN
            if s.ndim == 0:
                Rs = s * Ri
                return Rs @ Rs.T
            Rs = s[:, None, None] * Ri[None]
            return Rs @ np.swapaxes(Rs, -1, -2)

    @property
    def stderr(self):
        """Standard errors √diag(cov): shape (n,) or (n, p); a Series for a DataFrame ``Phi``.

        An entry that overflows float64 is inf, with a :class:`~adaptid.PrecisionWarning`.
        """
        return self._by_param(self._stderr)

    @cached_property
    def _stderr(self) -> np.ndarray:
        d = np.hypot.reduce(self._Rinv, axis=1)  # row norms of R⁻¹ without overflow
        s = np.sqrt(np.asarray(self.sigma2))
        with np.errstate(over="ignore", invalid="ignore"):
            out = d * s if s.ndim == 0 else d[:, None] * s[None, :]
        if np.isinf(out).any():
            warnings.warn("lstsq: standard errors overflow float64 (inf): the design is "
                          "nearly singular in absolute terms or the residuals are huge; "
                          "rescale the columns of Phi or y", PrecisionWarning, stacklevel=2)
        return out

    def conf_int(self, alpha=0.05):
        r"""Two-sided (1 − α) confidence intervals from Student's t with N − n dof.

        Returns
        -------
        ndarray, shape (n, 2) or (n, p, 2); or DataFrame, shape (n, 2)
            Lower and upper bounds. For a DataFrame ``Phi`` and one output, a
            DataFrame indexed by its columns with columns 0 (lower) and 1
            (upper), as statsmodels' ``conf_int()``; several outputs keep the
            (n, p, 2) array.
        """
        alpha = check_scalar(alpha, "alpha", low=0.0, high=1.0, low_open=True, high_open=True)
        if self.dof <= 0:
            raise ValueError("conf_int needs N > n (no residual degrees of freedom)")
        q = stats.t.ppf(1 - alpha / 2, self.dof)
        half = q * self._stderr
        out = np.stack([self.theta - half, self.theta + half], axis=-1)
        if self._columns is not None and self._single:
            import pandas as pd

            return pd.DataFrame(out, index=self._columns)       # columns 0, 1: a RangeIndex
        return out

    def __repr__(self):
        return f"LSResult(theta={np.array2string(np.asarray(self.theta), precision=6)}, dof={self.dof})"


def lstsq(Phi, y, *, weights=None, ridge=0.0) -> LSResult:
    r"""Weighted, ridge-regularised least squares by QR.

    Minimises

    .. math::

        \sum_k w_k (y_k - \varphi_k^T\theta)^2 + \text{ridge}\,\|\theta\|^2

    by a Householder QR of the stacked system
    :math:`\begin{bmatrix} W^{1/2}\Phi \\ \sqrt{\text{ridge}}\,I\end{bmatrix}`
    (never forming ΦᵀΦ), so the accuracy depends on cond(Φ), not cond(Φ)².
    The covariance is :math:`\hat\sigma^2 (\Phi^T W\Phi + \text{ridge}\,I)^{-1}
    = \hat\sigma^2 R^{-1}R^{-T}`, from triangular solves, with
    :math:`\hat\sigma^2 = \sum_k w_k r_k^2/(N - n)` (ordinary and weighted LS
    as in statsmodels' OLS / WLS).

    Parameters
    ----------
    Phi : array_like, shape (N, n); or pandas DataFrame
        Regressors, finite: one row per sample of ``y``. A DataFrame labels
        the results by its columns and rows, as statsmodels does (see
        :class:`LSResult`).
    y : array_like, shape (N,), (N, 1) or (N, p); or pandas Series / DataFrame
        Outputs, finite; p outputs share Φ. One output as a column (N, 1)
        is squeezed to (N,): the results are those of a single output (as
        :class:`~adaptid.IDData` and statsmodels treat it).
    weights : array_like, shape (N,), optional
        wₖ ≥ 0 (default 1).
    ridge : float
        ≥ 0; the Tikhonov term (as in ridge-regularised RLS: P[N] = (Σ φφᵀ + αI)⁻¹).

    Returns
    -------
    LSResult

    Raises
    ------
    ValueError
        On wrong shapes (a ``Phi`` of shape (n, N), transposed, is named
        with the fix ``Phi.T``), non-finite data, negative weights or ridge,
        or a rank-deficient design with ``ridge == 0`` (the parameters are
        then not identifiable: add ``ridge`` or remove columns).

    Examples
    --------
    >>> import numpy as np, adaptid
    >>> Phi = np.column_stack([np.ones(5), np.arange(5.0)])
    >>> res = adaptid.lstsq(Phi, 1.0 + 2.0 * np.arange(5.0))
    >>> np.allclose(res.theta, [1.0, 2.0])
    True

    A DataFrame of regressors gives results labelled by its columns:

    >>> import pandas as pd
    >>> X = pd.DataFrame(Phi, columns=["const", "slope"])
    >>> adaptid.lstsq(X, 1.0 + 2.0 * np.arange(5.0)).params.round(12).to_dict()
    {'const': 1.0, 'slope': 2.0}
    """
    frame = hasattr(Phi, "columns") and hasattr(Phi, "index")
    labels = {}
    if frame:
        labels = dict(_columns=Phi.columns, _rows=Phi.index)
    names = tuple(str(c) for c in Phi.columns) if hasattr(Phi, "columns") else None
    y_cols = getattr(y, "columns", None)
    Phi = as_float_array(Phi, "Phi", ndim=2)
    N, n = Phi.shape
    Y = as_float_array(y, "y", ndim=(1, 2))
    if Y.shape[0] != N and n == Y.shape[0]:
        raise param_error("Phi", f"of shape (N, n) with one row per sample of y (N={Y.shape[0]}); "
                          "it looks transposed: pass Phi.T", f"<shape {Phi.shape}>")
    if n == 0:
        raise param_error("Phi", "of shape (N, n) with n >= 1", f"<shape {Phi.shape}>")
    if N == 0:
        raise param_error("Phi", "of shape (N, n) with N >= 1 rows (no samples were given)",
                          f"<shape {Phi.shape}>")
    if Y.shape[0] != N:
        raise param_error("y", f"of length N={N} (rows of Phi)", f"<shape {Y.shape}>")
    if Y.ndim == 2 and Y.shape[1] == 1:     # one output as a column: squeezed, as IDData does
        Y = Y[:, 0]
    single = Y.ndim == 1
    if frame and not single:
        labels["_outputs"] = y_cols if y_cols is not None else None
    Y2 = Y.reshape(N, -1)
    ridge = check_scalar(ridge, "ridge", low=0.0)
    if weights is None:
        sw = w = None
    else:
        w = as_float_array(weights, "weights", shape=(N,))
        if (w < 0).any():
            raise param_error("weights", "non-negative", "<negative entries>")
        sw = np.sqrt(w)
    if N + (n if ridge > 0 else 0) < n:
        raise param_error("Phi", f"with at least n={n} rows (or ridge > 0)", f"<{N} rows>")
    with np.errstate(over="ignore", invalid="ignore"):
        A = Phi if sw is None else Phi * sw[:, None]
        B = Y2 if sw is None else Y2 * sw[:, None]
    if sw is not None and not (np.isfinite(A).all() and np.isfinite(B).all()):
        raise param_error("weights", "such that sqrt(weights) * Phi and sqrt(weights) * y are "
                          "representable in float64", "<an overflow>")
    if ridge > 0:
        A = np.vstack([A, np.sqrt(ridge) * np.eye(n)])
        B = np.vstack([B, np.zeros((n, B.shape[1]))])
    Q, R = linalg.qr(A, mode="economic")
    d = np.abs(np.diag(R))
    tol = max(A.shape) * np.finfo(float).eps * (d.max() if d.size else 0.0)
    rank = int(np.count_nonzero(d > tol))
    if rank < n:
        raise param_error("Phi", f"of full column rank n={n} (or use ridge > 0)",
                          f"<a design of numerical rank {rank}>")
    with np.errstate(over="ignore", invalid="ignore"):
        theta = linalg.solve_triangular(R, Q.T @ B, lower=False)
    if not np.all(np.isfinite(theta)):
        raise param_error("Phi", "scaled so that the solution is representable in float64 "
                          "(rescale the columns of Phi or y)", "<a solution that overflows>")
    with np.errstate(over="ignore", invalid="ignore"):  # residuals past 1e154: σ̂² = inf
        resid = Y2 - Phi @ theta
        wr2 = resid ** 2 if sw is None else (sw[:, None] * resid) ** 2
        dof = N - n
        sigma2 = wr2.sum(axis=0) / dof if dof > 0 else np.full(Y2.shape[1], np.nan)
    # constant columns, as statsmodels counts them (k_constant): zero range, non-zero value
    k_const = int(np.count_nonzero((np.ptp(Phi, axis=0) == 0) & (Phi[0] != 0))) if N else 0
    k_const = min(k_const, 1)
    extra = dict(_y=Y2, _weights=w, _k_constant=k_const, names=names, **labels)
    if single:
        return LSResult(theta=theta[:, 0], residuals=resid[:, 0], sigma2=float(sigma2[0]),
                        dof=dof, rank=rank, _R=R, _single=True, **extra)
    return LSResult(theta=theta, residuals=resid, sigma2=sigma2, dof=dof, rank=rank,
                    _R=R, _single=False, **extra)
